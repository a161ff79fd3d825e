// The page's code: reads the JSON island #data and draws a `pipeline derive` run's page (or the
// paper's, or a `derive --shader` run's). Every text of the data enters the document as text
// (textContent), never as markup.
(() => {
  "use strict";
  const data = JSON.parse(document.getElementById("data").textContent);
  const main = document.getElementById("page");
  const state = { arch: null, overlay: "", form: null, views: {}, live: null, sphere: null, errors: [] };
  window.pageState = state;
  window.addEventListener("error", (e) => state.errors.push(String(e.message)));

  // ---- small helpers -------------------------------------------------------------------------
  function el(tag, props, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(props || {})) {
      if (v == null) continue;
      if (k === "class") e.className = v;
      else if (k === "text") e.textContent = v;
      else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
      else if (k === "dataset") Object.assign(e.dataset, v);
      else e.setAttribute(k, v);
    }
    for (const c of children.flat(Infinity)) {
      if (c != null) e.append(c instanceof Node ? c : document.createTextNode(String(c)));
    }
    return e;
  }
  const num = (v) => (typeof v === "number" ? v : v === "inf" ? Infinity : v === "-inf" ? -Infinity : NaN);
  function fmt(v, digits = 4) {
    v = num(v);
    if (!Number.isFinite(v)) return String(v);
    if (v === 0) return "0";
    const a = Math.abs(v);
    return a >= 1e-3 && a < 1e5 ? String(Number(v.toPrecision(digits))) : v.toExponential(digits - 1);
  }
  function facts(pairs) {
    return el("dl", { class: "facts" }, pairs.filter((p) => p[1] != null && p[1] !== "")
      .map(([k, v]) => [el("dt", { text: k }), el("dd", {}, v)]));
  }
  function table(head, rows, onPick, id) {
    const body = el("tbody");
    for (const row of rows) {
      const tr = el("tr", { class: onPick ? "pick" : null, dataset: row.key ? { key: row.key } : null,
        onclick: onPick ? () => onPick(row.key) : null });
      for (const cell of row.cells) {
        if (cell instanceof Node) tr.append(el("td", {}, cell));
        else if (typeof cell === "object" && cell !== null) tr.append(el("td", { class: cell.class, text: cell.text }));
        else tr.append(el("td", { class: typeof cell === "number" ? "num" : null, text: typeof cell === "number" ? fmt(cell) : cell }));
      }
      body.append(tr);
    }
    if (!rows.length) body.append(el("tr", {}, el("td", { colspan: head.length, class: "note", text: "(none)" })));
    return el("table", { id }, el("thead", {}, el("tr", {}, head.map((h) => el("th", { text: h })))), body);
  }
  async function embed(node, spec, key) {
    if (state.views[key]) state.views[key].finalize();
    const result = await window.vegaEmbed(node, spec, { actions: false, renderer: "svg" });
    state.views[key] = result.view;
    return result.view;
  }
  function copyButton(getText) {
    const b = el("button", { class: "copy", text: "copy" });
    b.addEventListener("click", async () => {
      const text = getText();
      try { await navigator.clipboard.writeText(text); b.textContent = "copied"; }
      catch (e) {
        const area = el("textarea", {}, text);
        document.body.append(area); area.select();
        b.textContent = document.execCommand("copy") ? "copied" : "select and copy";
        area.remove();
      }
      setTimeout(() => { b.textContent = "copy"; }, 1500);
    });
    return b;
  }

  // ---- the error-against-cycles front ---------------------------------------------------------
  const SHAPES = { found: "circle", anchor: "triangle-up", exact: "diamond" };
  function frontPoints(arch) {
    const floor = num(data.floor) || 0;
    return (data.rows[arch] || []).map((r) => {
      const error = num(r.error);
      return { ...r, arch, error, shown: Math.max(error, floor > 0 ? floor / 2 : 1e-18), shape: SHAPES[r.kind] || "square",
        label: r.kind === "found" ? (r.on_front ? "front member" : "found") : r.kind };
    }).filter((p) => Number.isFinite(p.error) && Number.isFinite(num(p.cycles)));
  }
  function frontSpec(points, floor, title, width = 640) {
    const layers = [
      { mark: { type: "line", point: false, interpolate: "step-after", opacity: 0.5, color: "#555" },
        transform: [{ filter: "datum.on_front && datum.kind === 'found'" }, { calculate: "datum.arch + ' ' + datum.front", as: "series" }],
        encoding: { x: { field: "cycles", type: "quantitative" }, y: { field: "shown", type: "quantitative" },
          detail: { field: "series", type: "nominal" }, strokeDash: { field: "front", type: "nominal", title: "front", legend: points.some((p) => p.front) ? {} : null },
          order: { field: "cycles" } } },
      { mark: { type: "point", filled: true, size: 80, cursor: "pointer" }, name: "points_layer",
        encoding: {
          x: { field: "cycles", type: "quantitative", title: "cycles (cost model)" },
          y: { field: "shown", type: "quantitative", scale: { type: "log" }, title },
          color: points.some((p) => p.arch !== points[0].arch)
            ? { field: "arch", type: "nominal", title: "architecture" }
            : { field: "label", type: "nominal", title: "row", scale: { domain: ["front member", "found", "anchor", "exact"], range: ["#1f5fbf", "#9bb3d9", "#d9480f", "#2b8a3e"] } },
          shape: { field: "kind", type: "nominal", title: "kind", scale: { domain: ["found", "anchor", "exact"], range: ["circle", "triangle-up", "diamond"] } },
          opacity: { condition: { test: "datum.on_front || datum.kind !== 'found'", value: 1 }, value: 0.35 },
          tooltip: [{ field: "name" }, { field: "kind" }, { field: "arch", title: "architecture" }, { field: "cycles" },
            { field: "error", title: "error", format: ".4~g" }, { field: "expression" }] } },
    ];
    if (floor > 0) {
      layers.push({ data: { values: [{ floor, text: "rounding floor" }] }, mark: { type: "rule", strokeDash: [4, 4], color: "#777" },
        encoding: { y: { field: "floor", type: "quantitative" } } });
    }
    return { width, height: 360,
      data: { name: "points", values: points }, layer: layers };
  }

  // ---- a derive run's page ------------------------------------------------------------------
  function derivePage() {
    const t = data.target;
    const archs = data.architectures;
    state.arch = archs.length ? archs[0].name : null;
    main.replaceChildren();
    main.append(el("h1", { text: data.title }));
    main.append(facts([
      ["expression", el("code", { text: t.expression })], ["domain", t.domain_text], ["error", data.error_label],
      ["precision", t.precision], ["description", t.description],
      ["rerun", el("span", {}, el("code", { text: data.command }), copyButton(() => data.command))],
      ...data.summary,
    ]));
    if (data.notes.length) main.append(el("ul", { class: "note" }, data.notes.map((n) => el("li", { text: n }))));

    main.append(el("h2", { text: "Error against cycles, per GPU" }));
    const gpu = el("select", { id: "gpu" });
    const overlay = el("select", { id: "overlay" }, el("option", { value: "", text: "none" }));
    for (const [vendor, members] of Object.entries(groupBy(archs, (a) => a.vendor_title))) {
      gpu.append(el("optgroup", { label: vendor }, members.map((a) => el("option", { value: a.name, text: `${a.title} (${a.name})` }))));
      overlay.append(el("optgroup", { label: vendor }, members.map((a) => el("option", { value: a.name, text: `${a.title} (${a.name})` }))));
    }
    const model = el("p", { class: "note", id: "cost-model" });
    main.append(el("div", { class: "controls" }, el("label", {}, "GPU ", gpu), el("label", {}, "overlay ", overlay)), model);
    const plot = el("div", { id: "front-plot" });
    const rowsBox = el("div", { class: "scroll", id: "front-rows" });
    main.append(el("div", { class: "row" }, plot, rowsBox));
    const formBox = el("section", { id: "form" }, el("p", { class: "note", text: "Click a point or a row to open its form." }));
    main.append(formBox);
    main.append(el("h2", { text: "The hand fits (anchors) against the fronts" }));
    main.append(verdictTable());
    const renderedBox = el("section", { id: "rendered" });
    if (data.rendered) main.append(el("h2", { text: "As seen: each form rendered in its place, compared by FLIP" }), renderedBox);
    // the rendered comparison on the selected GPU: the rule's answer beside the max-error budget's
    function drawRendered() {
      const R = data.rendered;
      if (!R) return;
      if (R.why) { renderedBox.replaceChildren(el("p", { class: "note", text: `Not rendered: ${R.why}.` })); return; }
      const a = R.architectures[state.arch] || {};
      const named = (x, value) => x ? `${x.name} (${x.kind}, ${fmt(x.cycles)} cycles, ${value})` : "none";
      renderedBox.replaceChildren(
        el("p", {}, `Each form replaces ${R.what}; the rule: ${R.rule} (${fmt(R.threshold, 3)} here).`),
        facts([["cheapest invisible", named(a.cheapest_invisible, a.cheapest_invisible ? `largest FLIP ${fmt(a.cheapest_invisible.flip, 3)}` : "")],
               ["cheapest within the max-error budget", named(a.cheapest_within_budget, a.cheapest_within_budget ? `error ${fmt(a.cheapest_within_budget.error, 3)}` : "")],
               ["least FLIP (the exact target aside)", named(a.least_flip, a.least_flip ? `largest FLIP ${fmt(a.least_flip.flip, 3)}` : "")],
               ["max-error budget", `${fmt(R.budget, 3)}: ${R.budget_is}`]]),
        table(["anchor", "cycles", "its largest FLIP", "verdict by FLIP", "by", "its FLIP"],
          Object.entries(a.anchors || {}).map(([name, v]) => ({ cells: [name, num(v.cycles), num(v.flip), v.verdict, v.by || "", num(v.rival_flip)] })), null, "rendered-verdicts"));
      if (R.png) renderedBox.append(el("figure", {}, el("img", { class: "figure", alt: "the renders and their FLIP maps", src: `data:image/png;base64,${R.png}` }),
        el("figcaption", { class: "note", text: "renders.png: the exact term, the anchors and the first GPU's FLIP front, each beside its FLIP map." })));
    }
    if (data.special.length) {
      main.append(el("h2", { text: "Special functions on the selected GPU" }));
      main.append(el("div", { id: "special" }));
    }

    async function drawFront() {
      const a = archs.find((x) => x.name === state.arch);
      model.textContent = a ? `${a.title}: ${a.cost_model}` : "";
      const points = frontPoints(state.arch).concat(state.overlay && state.overlay !== state.arch ? frontPoints(state.overlay) : []);
      await embed(plot, frontSpec(points, num(data.floor), data.error_label), "front");
      state.views.front.addEventListener("click", (ev, item) => {
        if (item && item.datum && item.datum.name && data.forms[item.datum.name]) openForm(item.datum.name);
      });
      plot.dataset.points = String(points.filter((p) => p.arch === state.arch).length);
      const rows = (data.rows[state.arch] || []).slice().sort((p, q) => num(p.cycles) - num(q.cycles));
      const flips = rows.some((r) => r.flip != null);
      rowsBox.replaceChildren(table(["name", "kind", "cycles", "error", "front"].concat(flips ? ["largest FLIP"] : []),
        rows.map((r) => ({ key: r.name, cells: [r.name, r.kind, num(r.cycles), num(r.error), r.on_front ? "yes" : ""].concat(flips ? [num(r.flip)] : []) })),
        (name) => openForm(name), "front-table"));
      drawRendered();
      const special = document.getElementById("special");
      if (special) {
        special.replaceChildren(table(["function", "accuracy", "source", "Mesa's own lowering"],
          (data.special.find((s) => s.arch === state.arch) || { functions: [] }).functions.map((f) => ({
            cells: [f.function, f.accuracy, f.source, f.mesa ? "yes: executed as such" : ""] }))));
      }
      if (state.form) openForm(state.form);
    }
    gpu.addEventListener("change", () => { state.arch = gpu.value; drawFront(); });
    overlay.addEventListener("change", () => { state.overlay = overlay.value; drawFront(); });
    state.selectGpu = (name) => { gpu.value = name; state.arch = name; return drawFront(); };
    state.openForm = (name) => openForm(name);

    async function openForm(name) {
      const f = data.forms[name];
      if (!f) return;
      state.form = name;
      for (const tr of document.querySelectorAll("#front-table tbody tr")) tr.classList.toggle("chosen", tr.dataset.key === name);
      const row = (data.rows[state.arch] || []).find((r) => r.name === name);
      formBox.replaceChildren(el("h3", { text: `${name} (${f.kind})` }));
      formBox.append(facts([
        ["expression", el("code", { text: f.expression })], ["source", f.source],
        ["error as executed", row ? `${fmt(row.error)} on ${state.arch}` + ({
          exhaustive: " (certified: the largest over every input of the domain)",
          proven: " (certified: a bound proven over the whole box, within 1.25x of the largest found)",
          budget: " (certified: a bound proven over the whole box, reached at the budget of boxes)",
          sampled: " (sampled: not certified)" }[row.certified] || " (the largest of the inputs tried)")
          : "not on this GPU"],
        ["error as executed, sampled", row && row.certified ? fmt(row.error_sampled) : null],
        ["the worst a conforming driver may give (Vulkan's allowances, proven)", row && row.error_spec != null
          ? fmt(row.error_spec) : null],
        ["error of its mathematics (float64)", row ? fmt(row.error_real) : null],
        ["cycles", row ? `${fmt(row.cycles)} on ${state.arch}` : null],
      ]));
      const curveBox = el("div", { id: "curve" });
      const toggles = el("div", { class: "controls" });
      formBox.append(el("h3", { text: data.curves.title }), toggles, curveBox);
      const shown = { anchors: false, exact: true };
      for (const key of ["anchors", "exact"]) {
        const box = el("input", { type: "checkbox", id: `show-${key}` });
        box.checked = shown[key];
        box.addEventListener("change", () => { shown[key] = box.checked; drawCurve(); });
        toggles.append(el("label", {}, box, ` ${key === "exact" ? "the exact target as executed" : "the anchors"}`));
      }
      async function drawCurve() {
        const names = [name].concat(shown.anchors ? data.anchors : [], shown.exact && data.exact ? [data.exact] : [])
          .filter((n, i, all) => all.indexOf(n) === i && data.curves.error[n]);
        if (data.curves.kind === "none") { toggles.replaceChildren(); return; }      // (the title says why)
        if (data.curves.kind === "line") {
          const values = [];
          for (const n of names) data.curves.error[n].forEach((e, i) => values.push({ x: data.curves.x[i], error: e, form: n }));
          await embed(curveBox, { width: 640, height: 240, data: { values },
            mark: { type: "line", strokeWidth: 1.5 },
            encoding: { x: { field: "x", type: "quantitative", title: data.curves.variable },
              y: { field: "error", type: "quantitative", title: data.curves.axis },
              color: { field: "form", type: "nominal" }, tooltip: [{ field: "form" }, { field: "x" }, { field: "error", format: ".4~g" }] } }, "curve");
        } else {
          const c = data.curves, values = [];
          c.error[name].forEach((plane, k) => plane.forEach((line, i) => line.forEach((e, j) =>
            values.push({ k, p: c.parameter.values[k], u: c.axes[0][i], v: c.axes[1][j], error: e }))));
          await embed(curveBox, { width: 360, height: 320, data: { values },
            params: [{ name: "k", value: Math.floor(c.parameter.values.length / 2),
              bind: { input: "range", min: 0, max: c.parameter.values.length - 1, step: 1, name: `${c.parameter.name} (index of ${c.parameter.values.map((v) => fmt(v, 3)).join(", ")}) ` } }],
            transform: [{ filter: "datum.k == k" }],
            mark: "rect",
            encoding: { x: { field: "u", type: "ordinal", title: c.names[0], axis: { format: ".2f", labelOverlap: true } },
              y: { field: "v", type: "ordinal", title: c.names[1], sort: "descending", axis: { format: ".2f", labelOverlap: true } },
              color: { field: "error", type: "quantitative", title: c.axis, scale: { scheme: "redblue", domainMid: 0, reverse: true } },
              tooltip: [{ field: "p", title: c.parameter.name }, { field: "u", title: c.names[0] }, { field: "v", title: c.names[1] }, { field: "error", format: ".4~g" }] } }, "curve");
        }
      }
      await drawCurve();
      // the code, as derive.glsl, derive.hlsl and derive_twin.py hold it
      const code = el("pre", { id: "code" });
      const tabs = el("div", { class: "tabs" });
      let language = "glsl";
      const showCode = () => {
        code.textContent = f.code[language] || "(not exported: only front members, anchors and the exact target have code here)";
        for (const b of tabs.querySelectorAll("button[data-language]")) b.classList.toggle("on", b.dataset.language === language);
      };
      for (const [key, label] of [["glsl", "GLSL"], ["hlsl", "HLSL"], ["python", "Python"]]) {
        tabs.append(el("button", { text: label, dataset: { language: key }, onclick: () => { language = key; showCode(); } }));
      }
      tabs.append(copyButton(() => code.textContent));
      formBox.append(el("h3", { text: "Code" }), tabs, code);
      showCode();
      formBox.append(el("h3", { text: `Machine code on ${state.arch} (the listing its cycles were counted from)` }),
        el("pre", { id: "listing", text: (f.listing && f.listing[state.arch]) || "(no listing kept for this GPU)" }));
      formBox.append(el("h3", { text: "Cycles on every GPU of the run" }),
        table(["GPU", "cycles"], archs.filter((a) => f.cycles[a.name] != null).map((a) => ({ cells: [`${a.title} (${a.name})`, num(f.cycles[a.name])] }))));
      formBox.append(el("h3", { text: "Live: the shader in this browser (WebGL2)" }));
      live(formBox, name);
    }
    return drawFront();
  }
  function groupBy(items, key) {
    const out = {};
    for (const i of items) (out[key(i)] = out[key(i)] || []).push(i);
    return out;
  }
  function verdictTable() {
    const anchors = data.verdict_columns;
    return table(["GPU"].concat(anchors), data.architectures.map((a) => ({ cells: [`${a.title} (${a.name})`].concat(anchors.map((n) => {
      const v = (data.verdicts[a.name] || {})[n];
      return v ? { class: v.verdict, text: `${v.verdict} ${fmt(v.ratio, 3)}x${v.by ? ` by ${v.by}` : ""}` } : "";
    })) })), null, "verdicts");
  }


  // ---- the paper's page -----------------------------------------------------------------------
  function paperPage() {
    main.replaceChildren(el("h1", { text: data.title }), facts(data.summary));
    // the checks, filterable
    main.append(el("h2", { text: "Checks against the paper" }));
    const verdicts = ["all"].concat([...new Set(data.checks.map((c) => c.verdict === "pass" ? `pass (${c.held})` : c.verdict))]);
    const filter = el("select", { id: "check-filter" }, verdicts.map((v) => el("option", { value: v, text: v })));
    const checksBox = el("div", { id: "checks" });
    main.append(el("div", { class: "controls" }, el("label", {}, "show ", filter)), checksBox);
    const drawChecks = () => {
      const shown = data.checks.filter((c) => filter.value === "all" || filter.value === (c.verdict === "pass" ? `pass (${c.held})` : c.verdict));
      checksBox.replaceChildren(table(["id", "quantity", "paper", "reproduced", "tolerance", "verdict", "why"],
        shown.map((c) => ({ key: c.id, cells: [c.id, c.quantity, c.paper, c.reproduced, c.tolerance, { class: c.verdict === "pass" ? "pass" : c.verdict === "FAIL" ? "missed" : "matched", text: c.verdict === "pass" ? `pass (${c.held})` : c.verdict }, c.reason] })),
        null, "checks-table"));
      checksBox.dataset.rows = String(shown.length);
    };
    filter.addEventListener("change", drawChecks);
    drawChecks();
    state.filterChecks = (v) => { filter.value = v; drawChecks(); };

    // the decision: per architecture and n range, for the chosen use, n per and precision
    main.append(el("h2", { text: "The decision per GPU and n range" }));
    const D = data.decision;
    if (!D.available) main.append(el("p", { class: "note", text: `Not decided: ${D.reason}` }));
    main.append(el("p", { class: "note", text: D.rule }));
    const pick = {};
    const controls = el("div", { class: "controls" });
    for (const key of ["use", "n_per", "precision"]) {
      const values = [...new Set(D.rows.map((r) => r[key]))];
      const s = el("select", { id: `decision-${key}` }, values.map((v) => el("option", { value: v, text: v })));
      pick[key] = s;
      s.addEventListener("change", () => drawDecision());
      controls.append(el("label", {}, `${key.replace("_", " ")} `, s));
    }
    const decisionBox = el("div", { id: "decision" });
    main.append(controls, decisionBox, el("p", { class: "note", text: "Click a cell to open that range's lobe front below." }));
    const drawDecision = () => {
      const rows = D.rows.filter((r) => ["use", "n_per", "precision"].every((k) => r[k] === pick[k].value));
      const ranges = [...new Set(rows.map((r) => r.range))];
      const archs = data.architectures.filter((a) => rows.some((r) => r.architecture === a.name));
      const body = archs.map((a) => ({ cells: [`${a.title} (${a.name})`].concat(ranges.map((range) => {
        const r = rows.find((x) => x.architecture === a.name && x.range === range);
        if (!r) return "";
        return el("a", { href: "#lobe", class: "cell", dataset: { arch: a.name, range }, text: r.winner ? `${r.winner} (${fmt(r.cycles)} cycles, max d ${fmt(100 * r.d, 3)} %)` : "none qualifies", title: r.reason,
          onclick: (ev) => { ev.preventDefault(); showLobe(a.name, range); } });
      })) }));
      decisionBox.replaceChildren(table(["GPU"].concat(ranges), body, null, "decision-table"));
    };
    drawDecision();

    // the lobe search's fronts
    main.append(el("h2", { id: "lobe", text: "The lobe search's fronts: max d against compiled cycles" }));
    const gpu = el("select", { id: "lobe-gpu" });
    for (const [vendor, members] of Object.entries(groupBy(data.architectures, (a) => a.vendor_title))) {
      gpu.append(el("optgroup", { label: vendor }, members.map((a) => el("option", { value: a.name, text: `${a.title} (${a.name})` }))));
    }
    const range = el("select", { id: "lobe-range" }, data.ranges.map((r) => el("option", { value: r, text: r })));
    const plot = el("div", { id: "front-plot" });
    const rowsBox = el("div", { class: "scroll", id: "front-rows" });
    const costPlot = el("div", { id: "cost-plot" });
    main.append(el("div", { class: "controls" }, el("label", {}, "GPU ", gpu), el("label", {}, "range ", range)), el("div", { class: "row" }, plot, rowsBox),
      el("h3", { text: "The decision's candidates there (Phong lobe, n per material, fp32): max d against cycles, the budget dashed, the winner ringed" }), costPlot);
    async function showLobe(arch, r) {
      if (arch) gpu.value = arch;
      if (r) range.value = r;
      state.arch = gpu.value; state.range = range.value;
      const points = ((data.fronts[state.arch] || {})[state.range] || []).map((p) => ({ ...p, arch: state.arch,
        error: num(p.error), shown: Math.max(num(p.error), 1e-16), label: p.kind === "found" ? (p.on_front ? "front member" : "found") : p.kind }))
        .filter((p) => Number.isFinite(p.error));
      await embed(plot, frontSpec(points, 0, "max d (relative error in the epicenter zone)"), "front");
      plot.dataset.points = String(points.length);
      plot.dataset.arch = state.arch; plot.dataset.range = state.range;
      const winner = (data.decision.rows.find((r) => r.architecture === state.arch && r.range === state.range
        && r.use === "phong" && r.n_per === "material" && r.precision === "fp32") || {}).winner;
      const cands = ((data.candidates.by_range || {})[state.range] || [])
        .filter((c) => c.cycles[state.arch] != null && num(c.d) > 0)
        .map((c) => ({ ...c, cycles: num(c.cycles[state.arch]), d: num(c.d), winner: c.name === winner }));
      const layers = [{ mark: { type: "point", filled: true, size: 70 },
        encoding: { x: { field: "cycles", type: "quantitative", title: "cycles (cost model)" },
          y: { field: "d", type: "quantitative", scale: { type: "log" }, title: "max d" },
          color: { field: "kind", type: "nominal", title: "candidate" },
          tooltip: [{ field: "label" }, { field: "kind" }, { field: "cycles" }, { field: "d", title: "max d", format: ".4~g" }] } },
        { transform: [{ filter: "datum.winner" }], mark: { type: "point", filled: false, size: 260, strokeWidth: 2, color: "#111" },
          encoding: { x: { field: "cycles", type: "quantitative" }, y: { field: "d", type: "quantitative" } } }];
      if (data.candidates.max_d) layers.push({ data: { values: [{ budget: data.candidates.max_d }] }, mark: { type: "rule", strokeDash: [5, 4], color: "#b3261e" },
        encoding: { y: { field: "budget", type: "quantitative" } } });
      await embed(costPlot, { width: 640, height: 280, data: { name: "candidates", values: cands }, layer: layers }, "cost");
      costPlot.dataset.points = String(cands.length);
      rowsBox.replaceChildren(table(["name", "kind", "cycles", "max d", "front", "live"],
        points.slice().sort((p, q) => p.cycles - q.cycles).map((p) => ({ key: p.function || "", cells: [p.name, p.kind, p.cycles, p.error, p.on_front ? "yes" : "", p.function ? "open" : ""] })),
        (fn) => { if (fn) openLobe(fn); }, "front-table"));
      if (state.lobe && !points.some((p) => p.function === state.lobe)) { liveBox.replaceChildren(); state.lobe = null; state.live = null; }
    }
    const liveBox = el("section", { id: "lobe-live" });
    main.append(liveBox);
    function openLobe(fn) {
      state.lobe = fn;
      const [lo, hi] = state.range.replace("n in [", "").replace("]", "").split(", ").map(Number);
      liveBox.replaceChildren(el("h3", { text: `Live: ${fn} on a lit sphere beside cos^n (WebGL2)` }),
        el("pre", { id: "lobe-code", text: data.lobe_functions[fn] }));
      perN(fn, lo, hi);
      const gl = document.createElement("canvas").getContext("webgl2");
      if (!gl || !gl.getExtension("EXT_color_buffer_float")) {
        liveBox.append(el("p", { class: "note", id: "live-note", text: "WebGL2 with float render targets is not available in this browser: the live sphere is not shown (the rest of the page works)." }));
        return;
      }
      const size = 160;
      const slider = el("input", { type: "range", id: "live-n", min: lo, max: hi, step: (hi - lo) / 200, value: Math.sqrt(lo * hi) });
      const label = el("span");
      const canvas = el("canvas", { class: "live", id: "live", width: 3 * size + 40, height: size + 24 });
      const note = el("p", { class: "note" });
      liveBox.append(el("div", { class: "controls" }, el("label", {}, "n ", slider, label)), canvas, note);
      const fragment = "#version 300 es\nprecision highp float;\nout vec4 color;\nuniform float n;\nuniform float size;\n" + data.lobe_functions[fn] +
        "\nvoid main() {\n  vec2 p = (gl_FragCoord.xy - 0.5 * size) / (0.5 * size - 2.0);\n  float r2 = dot(p, p);\n" +
        "  if (r2 > 1.0) { color = vec4(0.0, 0.0, -1.0, 0.0); return; }\n  vec3 N = vec3(p, sqrt(1.0 - r2));\n" +
        "  vec3 L = normalize(vec3(0.35, 0.45, 1.0));\n  vec3 H = normalize(L + vec3(0.0, 0.0, 1.0));\n  float t = max(dot(N, H), 0.0);\n" +
        `  color = vec4(${fn}(t, n), pow(t, n), t, max(dot(N, L), 0.0));\n}\n`;
      const draw = () => {
        const n = Number(slider.value);
        label.textContent = ` = ${fmt(n, 4)}`;
        let out;
        try { out = runShader(gl, fragment, size, size, { n, size }); }
        catch (e) { note.textContent = `The shader did not compile in this browser: ${e.message}`; return; }
        state.live = { name: fn, n, values: Array.from(out) };
        const g = canvas.getContext("2d");
        g.clearRect(0, 0, canvas.width, canvas.height);
        const panels = [0, 1, 2].map(() => g.createImageData(size, size));
        let largest = 0;
        for (let i = 0; i < size * size; i++) if (out[4 * i + 2] >= 0) largest = Math.max(largest, Math.abs(out[4 * i] - out[4 * i + 1]));
        for (let row = 0; row < size; row++) for (let col = 0; col < size; col++) {
          const i = row * size + col, j = ((size - 1 - row) * size + col) * 4;
          if (out[4 * i + 2] < 0) continue;
          const lit = out[4 * i + 3];
          for (const k of [0, 1]) { const v = Math.min(1, out[4 * i + k] * lit + 0.08 * lit) * 255; panels[k].data.set([v, v, v, 255], j); }
          const d = (out[4 * i] - out[4 * i + 1]) / (largest || 1);
          panels[2].data.set(d >= 0 ? [255, 255 * (1 - d), 255 * (1 - d), 255] : [255 * (1 + d), 255 * (1 + d), 255, 255], j);
        }
        panels.forEach((p, k) => g.putImageData(p, 10 + k * (size + 10), 12));
        note.textContent = `Left: the form as the specular lobe (t = N.H, times N.L, a little diffuse); middle: cos^n; right: their difference (red above, blue below, full colour at its largest, ${fmt(largest)} of the peak), computed by this browser's GPU.`;
      };
      slider.addEventListener("input", draw);
      draw();
    }
    state.openLobe = openLobe;
    // the form's family fitted at each n of the range (its per-n optimum) beside the shipped line's max d
    function perN(fn, lo, hi) {
      const point = ((data.fronts[state.arch] || {})[state.range] || []).find((p) => p.function === fn);
      const curve = point && data.per_n && data.per_n.d[point.name];
      if (!curve) return;
      const values = data.per_n.n.map((n, i) => ({ n, d: num(curve[i]) })).filter((v) => v.n >= lo && v.n <= hi && Number.isFinite(v.d));
      const box = el("div", { id: "per-n-plot" });
      liveBox.append(el("h4", { text: `${point.name}: max d at each n, its parameters fitted at that n (the per-n optimum), and the shipped line's max d over the range (dashed)` }), box);
      embed(box, { width: 640, height: 200, layer: [
        { data: { values }, mark: { type: "line", point: true }, encoding: { x: { field: "n", type: "quantitative", scale: { type: "log" } },
          y: { field: "d", type: "quantitative", scale: { type: "log" }, title: "max d (relative, in the zone)" }, tooltip: [{ field: "n", format: ".4~g" }, { field: "d", format: ".4~g" }] } },
        { data: { values: [{ line: num(point.error) }] }, mark: { type: "rule", strokeDash: [5, 4], color: "#b3261e" }, encoding: { y: { field: "line", type: "quantitative" } } }] }, "per_n");
      box.dataset.points = String(values.length);
    }
    gpu.addEventListener("change", () => showLobe());
    range.addEventListener("change", () => showLobe());
    state.showLobe = showLobe;

    // figures: coef(n) redrawn, the others as the run drew them
    main.append(el("h2", { text: "Figures" }));
    const pending = [showLobe()];
    if (data.coef) {
      const box = el("div", { id: "coef-plot" });
      main.append(el("h3", { text: "Fig. 10, redrawn: the ideal normalization y(n), the sample, the fitted coef(n), and each line over y(n) - 1" }), box);
      const values = [];
      for (const c of data.coef.curves) c.n.forEach((n, i) => values.push({ n, coef: c.coef[i], residual: c.residual ? c.residual[i] : null, series: c.name }));
      const sample = data.coef.sample.n.map((n, i) => ({ n, coef: data.coef.sample.y[i], series: "sample" }));
      pending.push(embed(box, { vconcat: [
        { width: 640, height: 220, layer: [
          { data: { values }, mark: { type: "line" }, encoding: { x: { field: "n", type: "quantitative", scale: { type: "log" } },
            y: { field: "coef", type: "quantitative", scale: { type: "log" }, title: "coef(n) (1/sr)" }, color: { field: "series", type: "nominal", title: "" },
            tooltip: [{ field: "series" }, { field: "n", format: ".4~g" }, { field: "coef", format: ".6~g" }] } },
          { data: { values: sample }, mark: { type: "point", filled: true, size: 25, color: "#222" },
            encoding: { x: { field: "n", type: "quantitative" }, y: { field: "coef", type: "quantitative" }, tooltip: [{ field: "n" }, { field: "coef", format: ".6~g" }] } }] },
        { width: 640, height: 160, data: { values }, transform: [{ filter: "datum.residual !== null" }], mark: { type: "line" },
          encoding: { x: { field: "n", type: "quantitative", scale: { type: "log" } },
            y: { field: "residual", type: "quantitative", title: "over y(n) - 1 (%), > 0: energy created" },
            color: { field: "series", type: "nominal", title: "" }, tooltip: [{ field: "series" }, { field: "n", format: ".4~g" }, { field: "residual", format: ".3~g" }] } },
      ] }, "coef"));
    }
    if (data.albedo) {
      const A = data.albedo;
      const variant = el("select", { id: "albedo-variant" }, Object.keys(A.curves).map((v) => el("option", { value: v, text: v })));
      const box = el("div", { id: "albedo-plot" });
      main.append(el("h3", { text: "Directional albedo at every incidence angle (above 1: the lobe reflects more than arrives)" }),
        el("div", { class: "controls" }, el("label", {}, "form and coef ", variant)), box);
      const drawAlbedo = () => {
        const values = [];
        A.curves[variant.value].forEach((curve, i) => curve.forEach((albedo, j) => values.push({ theta: A.theta[j], albedo, n: A.n[i] })));
        return embed(box, { width: 640, height: 280, data: { values }, layer: [
          { mark: { type: "line" }, encoding: { x: { field: "theta", type: "quantitative", title: "incidence angle (degrees)" },
            y: { field: "albedo", type: "quantitative", title: "albedo (reflected / received)", scale: { zero: false } },
            color: { field: "n", type: "ordinal", title: "n" }, tooltip: [{ field: "n" }, { field: "theta", format: ".1f" }, { field: "albedo", format: ".5~g" }] } },
          { data: { values: [{ one: 1 }] }, mark: { type: "rule", strokeDash: [4, 4], color: "#555" }, encoding: { y: { field: "one", type: "quantitative" } } }] }, "albedo");
      };
      variant.addEventListener("change", drawAlbedo);
      pending.push(drawAlbedo());
    }
    for (const image of data.images) {
      main.append(el("figure", {}, el("img", { class: "figure", alt: image.caption, src: `data:image/png;base64,${image.png}` }),
        el("figcaption", { class: "note", text: `${image.file}: ${image.caption}` })));
    }
    return Promise.all(pending);
  }

  // ---- the live shader ----------------------------------------------------------------------
  const VERTEX = "#version 300 es\nvoid main() { vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0); gl_Position = vec4(p, 0.0, 1.0); }";
  function compile(gl, fragment) {
    const program = gl.createProgram();
    for (const [type, text] of [[gl.VERTEX_SHADER, VERTEX], [gl.FRAGMENT_SHADER, fragment]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, text);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      gl.attachShader(program, s);
    }
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
    return program;
  }
  function runShader(gl, fragment, width, height, uniforms) {
    const program = compile(gl, fragment);
    const texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, height, 0, gl.RGBA, gl.FLOAT, null);
    const fbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
    gl.viewport(0, 0, width, height);
    gl.useProgram(program);
    for (const [k, v] of Object.entries(uniforms)) gl.uniform1f(gl.getUniformLocation(program, k), v);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    const out = new Float32Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.FLOAT, out);
    return out;
  }
  function live(box, name) {
    const L = data.live;
    const f = data.forms[name];
    state.live = null;
    if (!L || !f.gles) {
      box.append(el("p", { class: "note", id: "live-note", text: (L && L.why) || "This form has no GLSL ES function to run." }));
      return;
    }
    const gl = document.createElement("canvas").getContext("webgl2");
    if (!gl || !gl.getExtension("EXT_color_buffer_float")) {
      box.append(el("p", { class: "note", id: "live-note", text: "WebGL2 with float render targets is not available in this browser: the live shader is not shown (the rest of the page works)." }));
      return;
    }
    const head = "#version 300 es\nprecision highp float;\nprecision highp int;\nout vec4 color;\n";
    try {
      if (L.kind === "line") {
        const fragment = head + "uniform float lo;\nuniform float hi;\nuniform float count;\n" + f.gles + "\n" + (L.exact || "") +
          `\nvoid main() {\n  float ${L.variable} = lo + (hi - lo) * floor(gl_FragCoord.x) / (count - 1.0);\n` +
          `  color = vec4(${f.call}, ${L.exact ? L.exact_call : "0.0"}, ${L.variable}, 1.0);\n}\n`;
        const out = runShader(gl, fragment, L.count, 1, { lo: L.lo, hi: L.hi, count: L.count });
        const x = [], form = [], exact = [];
        for (let i = 0; i < L.count; i++) { form.push(out[4 * i]); exact.push(out[4 * i + 1]); x.push(out[4 * i + 2]); }
        state.live = { name, x, form, exact };
        const canvas = el("canvas", { class: "live", id: "live", width: 640, height: 260 });
        box.append(canvas, el("p", { class: "note", text: `The form (blue) and the exact target (grey) computed by this browser's GPU at ${L.count} points; below, their difference (red, own scale: largest ${fmt(Math.max(...form.map((v, i) => Math.abs(v - exact[i]))))}).` }));
        drawLine(canvas, x, form, exact, Boolean(L.exact));
      } else if (L.kind === "heat") {
        const canvas = el("canvas", { class: "live", id: "live", width: 3 * L.size + 40, height: L.size + 24 });
        const slider = el("input", { type: "range", min: L.parameter.lo, max: L.parameter.hi, step: (L.parameter.hi - L.parameter.lo) / 200, value: L.parameter.middle, id: "live-parameter" });
        const label = el("span");
        box.append(el("div", { class: "controls" }, el("label", {}, `${L.parameter.name} `, slider, label)), canvas,
          el("p", { class: "note" }, `Left: the form; middle: the exact target (grey levels: one scale for both); right: their ${L.relative ? "relative " : ""}difference (red above, blue below, full colour at its largest, `,
            el("span", { id: "live-scale" }), `), over ${L.names[0]} (across) and ${L.names[1]} (up), computed by this browser's GPU.`));
        const draw = () => {
          const p = Number(slider.value);
          label.textContent = ` = ${fmt(p, 3)}`;
          const fragment = head + "uniform float size;\n" + f.gles + "\n" + (L.exact || "") +
            `\nvoid main() {\n  float ${L.names[0]} = ${L.lo[0]} + (${L.hi[0]} - ${L.lo[0]}) * (gl_FragCoord.x - 0.5) / (size - 1.0);\n` +
            `  float ${L.names[1]} = ${L.lo[1]} + (${L.hi[1]} - ${L.lo[1]}) * (gl_FragCoord.y - 0.5) / (size - 1.0);\n` +
            `  float ${L.parameter.name} = float(${p.toExponential(8)});\n` +
            `  color = vec4(${f.call}, ${L.exact ? L.exact_call : "0.0"}, 0.0, 1.0);\n}\n`;
          const out = runShader(gl, fragment, L.size, L.size, { size: L.size });
          state.live = { name, parameter: p, values: out };
          drawHeat(canvas, out, L);
        };
        slider.addEventListener("input", draw);
        draw();
      }
      if (L.sphere) sphere(box, gl, f, name);
    } catch (e) {
      box.append(el("p", { class: "note", id: "live-note", text: `The shader did not compile in this browser: ${e.message}` }));
    }
  }

  // The form in its role on a lit sphere (a light two radii from its centre, whose angle to the view
  // is on a slider, so that the inputs vary over the sphere; GGX's
  // D, the height-correlated Smith V and Schlick's F, the role's factor replaced), beside the exact
  // target in the same place and their difference.
  const SPHERE_SIZE = 160;
  function sphere(box, gl, f, name) {
    const S = data.live.sphere, size = SPHERE_SIZE;
    const roughness = el("input", { type: "range", id: "sphere-roughness", min: S.roughness[0], max: S.roughness[1], step: (S.roughness[1] - S.roughness[0]) / 200, value: 0.5 * (S.roughness[0] + S.roughness[1]) });
    const angle = el("input", { type: "range", id: "sphere-angle", min: 0, max: 170, step: 1, value: 100 });
    const material = el("select", { id: "sphere-material" }, el("option", { value: "0.04", text: "dielectric (F0 0.04)" }), el("option", { value: "0.95", text: "metal (F0 0.95)" }));
    const label = el("span");
    const canvas = el("canvas", { class: "live", id: "sphere", width: 3 * size + 40, height: size + 24 });
    const note = el("p", { class: "note" });
    box.append(el("h4", { text: `In its place: ${S.what}, on a lit sphere` }),
      el("div", { class: "controls" }, el("label", {}, "roughness ", roughness), el("label", {}, " light to view ", angle, "\u00b0"), el("label", {}, " ", material), label),
      canvas, note);
    const source = { VoH: "gVoH", NoV: "gNoV", NoL: "gNoL", NoH: "gNoH", alpha: "gAlpha", n: "gN" };
    const inputs = S.names.map((v, i) => `  float ${v} = clamp(${source[S.inputs[i]]}, ${S.lo[i]}, ${S.hi[i]});`).join("\n");
    const shade = (T) => {
      const F = S.role === "fresnel" ? `(F0 + (1.0 - F0) * ${T})` : "(F0 + (1.0 - F0) * pow(1.0 - gVoH, 5.0))";
      const Vis = S.role === "visibility" ? T : "smith(gNoV, gNoL, gAlpha)";
      const D = S.role === "lobe" ? `((gN + 2.0) / (2.0 * 3.14159265) * max(${T}, 0.0))` : "ggx(gNoH, gAlpha)";
      return `${D} * ${Vis} * ${F} * gNoL * 2.5 + (F0 < 0.5 ? 0.5 / 3.14159265 * gNoL * 2.5 : 0.0) + 0.12`;
    };
    const fragment = "#version 300 es\nprecision highp float;\nprecision highp int;\nout vec4 color;\nuniform float size;\nuniform float roughness;\nuniform float angle;\nuniform float F0;\n" +
      f.gles + "\n" + data.live.exact + "\n" +
      "float ggx(float t, float a) { float a2 = a * a; float d = t * t * (a2 - 1.0) + 1.0; return a2 / (3.14159265 * d * d); }\n" +
      "float smith(float v, float l, float a) { float a2 = a * a; return 0.5 / (l * sqrt(v * v * (1.0 - a2) + a2) + v * sqrt(l * l * (1.0 - a2) + a2)); }\n" +
      "void main() {\n  vec2 p = (gl_FragCoord.xy - 0.5 * size) / (0.5 * size - 2.0);\n  float r2 = dot(p, p);\n" +
      "  if (r2 > 1.0) { color = vec4(-1.0); return; }\n  vec3 gNormal = vec3(p, sqrt(1.0 - r2));\n  vec3 gView = vec3(0.0, 0.0, 1.0);\n" +
      "  vec3 gLight = normalize(2.0 * vec3(-sin(angle) * 0.6, sin(angle) * 0.8, cos(angle)) - gNormal);\n  vec3 gHalf = normalize(gLight + gView);\n" +
      "  float gNoV = gNormal.z, gNoL = max(dot(gNormal, gLight), 0.0), gNoH = clamp(dot(gNormal, gHalf), 0.0, 1.0), gVoH = clamp(dot(gView, gHalf), 0.0, 1.0);\n" +
      "  float gAlpha = roughness * roughness, gN = 2.0 / (gAlpha * gAlpha) - 2.0;\n" + inputs + "\n" +
      `  float form = ${f.call};\n  float exact = ${data.live.exact_call};\n` +
      `  color = vec4(${shade("form")}, ${shade("exact")}, ${S.names[0]}, form);\n}\n`;
    const draw = () => {
      const r = Number(roughness.value), a = Number(angle.value) * Math.PI / 180, F0 = Number(material.value);
      label.textContent = ` roughness ${fmt(r, 3)}, light ${angle.value}\u00b0 from the view`;
      let out;
      try { out = runShader(gl, fragment, size, size, { size, roughness: r, angle: a, F0 }); }
      catch (e) { note.textContent = `The sphere's shader did not compile in this browser: ${e.message}`; return; }
      const g = canvas.getContext("2d");
      g.clearRect(0, 0, canvas.width, canvas.height);
      const panels = [0, 1, 2].map(() => g.createImageData(size, size));
      let largest = 0;
      const x = [], term = [];
      for (let i = 0; i < size * size; i++) if (out[4 * i] >= 0) { largest = Math.max(largest, Math.abs(out[4 * i] - out[4 * i + 1])); x.push(out[4 * i + 2]); term.push(out[4 * i + 3]); }
      const display = (v) => 255 * Math.pow(Math.max(v, 0) / (1 + Math.max(v, 0)), 1 / 2.2);
      for (let row = 0; row < size; row++) for (let col = 0; col < size; col++) {
        const i = row * size + col, j = ((size - 1 - row) * size + col) * 4;
        if (out[4 * i] < 0) continue;
        for (const k of [0, 1]) { const v = display(out[4 * i + k]); panels[k].data.set([v, v, v, 255], j); }
        const d = (out[4 * i] - out[4 * i + 1]) / (largest || 1);
        panels[2].data.set(d >= 0 ? [255, 255 * (1 - d), 255 * (1 - d), 255] : [255 * (1 + d), 255 * (1 + d), 255, 255], j);
      }
      panels.forEach((p, k) => g.putImageData(p, 10 + k * (size + 10), 12));
      state.sphere = { name, roughness: r, angle: a, F0, x, term };
      note.textContent = `Left: the form in its place; middle: the exact target; right: their difference in radiance (red above, blue below, full colour at its largest, ${fmt(largest)}), computed by this browser's GPU (Reinhard tone map, gamma 2.2).`;
    };
    for (const control of [roughness, angle, material]) control.addEventListener("input", draw);
    draw();
  }

  function drawLine(canvas, x, form, exact, withExact) {
    const g = canvas.getContext("2d");
    const w = canvas.width, h = canvas.height, top = 160;
    const all = form.concat(withExact ? exact : []).filter(Number.isFinite);
    const lo = Math.min(...all), hi = Math.max(...all);
    const X = (i) => 30 + (w - 40) * i / (x.length - 1);
    const Y = (v) => 10 + (top - 20) * (1 - (v - lo) / ((hi - lo) || 1));
    g.clearRect(0, 0, w, h);
    const curve = (values, color, y) => {
      g.strokeStyle = color; g.lineWidth = 1.5; g.beginPath();
      values.forEach((v, i) => (i ? g.lineTo(X(i), y(v)) : g.moveTo(X(i), y(v))));
      g.stroke();
    };
    if (withExact) curve(exact, "#999", Y);
    curve(form, "#1f5fbf", Y);
    if (withExact) {
      const d = form.map((v, i) => v - exact[i]);
      const m = Math.max(...d.map(Math.abs)) || 1;
      g.strokeStyle = "#ddd"; g.beginPath(); g.moveTo(30, top + 45); g.lineTo(w - 10, top + 45); g.stroke();
      curve(d, "#c0392b", (v) => top + 45 - 40 * v / m);
    }
  }
  function drawHeat(canvas, out, L) {
    const g = canvas.getContext("2d");
    const n = L.size;
    g.clearRect(0, 0, canvas.width, canvas.height);
    const image = (k) => g.createImageData(n, n);
    const finite = [];
    for (let i = 0; i < n * n; i++) { if (Number.isFinite(out[4 * i + 1])) finite.push(out[4 * i + 1]); if (Number.isFinite(out[4 * i])) finite.push(out[4 * i]); }
    finite.sort((a, b) => a - b);
    const lo = finite[0], hi = finite[Math.floor(0.99 * (finite.length - 1))];
    const panels = [image(0), image(1), image(2)];
    // the difference's colour saturates at its largest value over the image (stated under it)
    let scale = 0;
    for (let i = 0; i < n * n; i++) {
      const d = (out[4 * i] - out[4 * i + 1]) / (L.relative ? Math.max(Math.abs(out[4 * i + 1]), 1e-30) : 1);
      if (Number.isFinite(d)) scale = Math.max(scale, Math.abs(d));
    }
    scale = scale || 1;
    const note = document.getElementById("live-scale");
    if (note) note.textContent = fmt(scale);
    for (let row = 0; row < n; row++) {
      for (let col = 0; col < n; col++) {
        const i = row * n + col, j = ((n - 1 - row) * n + col) * 4;
        const a = out[4 * i], b = out[4 * i + 1];
        for (const [k, v] of [[0, a], [1, b]]) {
          const s = Math.max(0, Math.min(1, (v - lo) / ((hi - lo) || 1))) * 255;
          panels[k].data.set([s, s, s, 255], j);
        }
        let d = L.exact ? (a - b) / (L.relative ? Math.max(Math.abs(b), 1e-30) : 1) / scale : 0;
        d = Math.max(-1, Math.min(1, d));
        panels[2].data.set(d >= 0 ? [255, 255 * (1 - d), 255 * (1 - d), 255] : [255 * (1 + d), 255 * (1 + d), 255, 255], j);
      }
    }
    panels.forEach((p, k) => { if (k < 2 || L.exact) g.putImageData(p, 10 + k * (n + 10), 12); });
  }

  // ---- a `derive --shader` run's page -------------------------------------------------------------
  function cyclesSpec(bars) {
    return { data: { values: bars }, facet: { column: { field: "architecture", type: "nominal", title: null } },
      spec: { width: 260, height: { step: 14 },
        mark: { type: "bar" },
        encoding: {
          y: { field: "function", type: "nominal", title: null, sort: null },
          yOffset: { field: "when", type: "nominal", sort: ["before", "after"] },
          x: { field: "cycles", type: "quantitative", title: "cycles (cost model)" },
          color: { field: "when", type: "nominal", title: "", sort: ["before", "after"], scale: { domain: ["before", "after"], range: ["#9bb3d9", "#1f5fbf"] } },
          tooltip: [{ field: "function" }, { field: "architecture" }, { field: "when" }, { field: "cycles" }] } } };
  }
  const STATUS_CLASS = { derived: "beaten", "none cheaper": "matched", refused: "missed" };
  const beforeAfter = (a, b) => (a == null ? "" : `${fmt(a)} → ${fmt(b)}`);
  async function shaderPage() {
    main.replaceChildren();
    main.append(el("h1", { text: data.title }));
    main.append(facts([["file", el("code", { text: data.file })], ["language", data.language],
      ["functions", data.counts], ["architectures", data.architectures.join(", ")], ...(data.totals || [])]));
    main.append(el("p", { class: "note", text: "The file is unchanged: shader.patch replaces the derived functions' bodies. Cycles are the cost model's per architecture; errors are as executed (fp32 or fp16 as the run's precision), against each function's own mathematics or the exact function its annotation names." }));
    if (data.bars.length) {
      main.append(el("h2", { text: "Cycles before and after, per GPU" }));
      const plot = el("div", { id: "cycles-plot" });
      main.append(plot);
      await embed(plot, cyclesSpec(data.bars), "cycles");
    }
    main.append(el("h2", { text: "Every function" }));
    const rows = [];
    data.functions.forEach((f, i) => {
      const link = () => el("a", { href: `#function-${i}`, text: f.name });
      const status = { class: STATUS_CLASS[f.status], text: f.status };
      if (!f.rows.length) rows.push({ cells: [link(), f.line, status, "", "", "", "", f.reason] });
      for (const r of f.rows) {
        rows.push({ cells: [link(), f.line, status, r.architecture, beforeAfter(r.cycles_before, r.cycles_after),
          beforeAfter(r.error_before, r.error_after), beforeAfter(r.flip_before, r.flip_after),
          f.page ? el("a", { href: f.page, text: "open" }) : ""] });
      }
    });
    main.append(table(["function", "line", "status", "architecture", "cycles", "error", "FLIP", "derive page"], rows, null, "functions-table"));
    data.functions.forEach((f, i) => {
      const box = el("section", { id: `function-${i}`, class: "function" });
      box.append(el("h3", {}, `${f.name} (line ${f.line}): `, el("span", { class: STATUS_CLASS[f.status], text: f.status })));
      if (f.reason) box.append(el("p", { text: f.reason }));
      box.append(facts([
        ["read as", f.read ? el("code", { text: f.read }) : null], ["checked", f.checked],
        ["replacement", f.expression ? el("span", {}, el("code", { text: f.expression }), copyButton(() => f.expression), ` (${f.replacement})`) : null],
        ["budget", f.budget != null ? `${f.metric} ${fmt(f.budget, 3)}` : null],
        ["derive page", f.page ? el("a", { href: f.page, text: f.page }) : null],
      ]));
      const platforms = Object.entries(f.platforms || {});
      if (platforms.length) {
        box.append(el("p", { class: "note", text: "Per platform, the one form every architecture of it runs (the least worst cycles within the budget), and what a variant per architecture would save." }));
        box.append(table(["platform", "form", "worst cycles", "error", "cycles per architecture", "a variant per architecture saves"],
          platforms.map(([name, a]) => ({ cells: a ? [name, a.name, a.worst, a.error, Object.entries(a.cycles).map(([k, c]) => `${k} ${fmt(c)}`).join(", "),
            Object.entries(a.variant_saving).filter(([, c]) => c > 0).map(([k, c]) => `${k} ${fmt(c)}`).join(", ") || "nothing"]
            : [name, "none within the budget", "", "", "", ""] })), null, `platforms-${i}`));
      }
      if (f.pieces.length) {
        box.append(el("p", { class: "note", text: "Its branch, each piece derived on the interval where it is taken" + (f.pieces_reason ? `: ${f.pieces_reason}` : "") + "." }));
        if (f.branch) {
          box.append(el("p", { class: "note", text: `The branch of the pieces' replacements, costed and measured whole: ${Object.entries(f.branch.cycles).map(([a, c]) => `${a} ${fmt(c)} cycles`).join(", ")}; error ${fmt(f.branch.error)}` + (f.replacement === f.branch.name ? " (the replacement)." : ".") }));
        }
        box.append(table(["#", "taken", "interval", "as shipped", "replacement", "error", "cycles"], f.pieces.map((p) => ({ cells: [
          p.page ? el("a", { href: p.page, text: String(p.index) }) : String(p.index), p.where, p.domain ? `[${fmt(p.domain[0])}, ${fmt(p.domain[1])}]` : "(a point)", p.shipped,
          p.form || p.reason || "", p.error ? beforeAfter(p.error.before, p.error.after) : "",
          p.cycles ? Object.entries(p.cycles).map(([a, c]) => `${a} ${beforeAfter(c.before, c.after)}`).join("; ") : ""] }))));
      }
      main.append(box);
    });
    main.append(el("h2", {}, "shader.patch", data.patch ? copyButton(() => data.patch) : null));
    main.append(data.patch ? el("pre", { id: "patch", text: data.patch }) : el("p", { class: "note", id: "patch", text: "No function was derived: the patch is empty." }));
  }

  // ---- start ----------------------------------------------------------------------------------
  Promise.resolve().then(() => (data.kind === "derive" ? derivePage() : data.kind === "paper" ? paperPage() : data.kind === "shader" ? shaderPage() : null))
    .then(() => { document.body.dataset.ready = "1"; })
    .catch((e) => {
      state.errors.push(String(e));
      main.append(el("pre", { text: `The page could not be drawn: ${e}` }));
      console.error(e);
    });
})();
