"""Data files of a run: the energy dataset (as the paper's newenergy.txt), the regression front and
the lobe search's rows as `pipeline derive` writes its fronts."""

from __future__ import annotations

from pathlib import Path

from ..approximate.publishing.derive_files import write_csv
from ..engine.exponents import n_range
from ..symbolic.regress import write_front_csv


def write(out: Path, config, results) -> None:
    """newenergy.csv, energy_all_n.csv, symbolic_front.csv, regression_front.csv and
    lobe_search_front.csv, each where the stages it is read from ran (a targeted run writes those of
    its stages)."""
    n_all = n_range(config)
    if "energy_dataset" in results:
        data = results["energy_dataset"]
        with open(out / "newenergy.csv", "w") as f:
            f.write("n, y\n")
            for n, y in zip(results["sample"]["sample_n"], data["sample_y"]):
                f.write(f"{int(n)}, {y:.12g}\n")
        with open(out / "energy_all_n.csv", "w") as f:
            f.write("n,Int,y,gran\n")
            for n, i, y, g in zip(n_all, data["Int"], data["y"], data["gran"]):
                f.write(f"{int(n)},{i:.17g},{y:.17g},{g:.17g}\n")
    if "symbolic_regression" in results:
        write_front_csv(out / "symbolic_front.csv", results["symbolic_regression"]["front"])
    if "sparse_regression" in results:
        reg = results["sparse_regression"]
        with open(out / "regression_front.csv", "w") as f:
            f.write("terms,expression,rms_sample,rms_all_n,threshold\n")
            f.write(f"1,{reg['constant_model']:.6g},{reg['constant_model_rms']:.6g},,\n")
            for m in reg["front"]:
                f.write(f"{len(m['terms'])},{m['expression']},{m['rms']:.6g},{m['rms_all_n']:.6g},"
                        f"{m['threshold']:.3g}\n")
    if results.get("lobe_search", {}).get("available"):
        write_csv(out / "lobe_search_front.csv", lobe_search_rows(results["lobe_search"]))


def lobe_search_rows(search) -> list[dict]:
    """The lobe search's candidates and placed lobes as `pipeline derive`'s front.csv rows
    (`approximate.publishing.derive_files.COLUMNS`): per architecture and range, each form with its parameters as
    lines in n (`parameter_per` material: computed once per material), max_rel_error its d with the
    best parameters per n (what the fronts rank), d_line with the lines (measured at every integer n),
    D and D_line the absolute errors over the whole lobe; the registry's lobes as anchors."""
    rows = []
    for c in search.get("candidates", []):
        parameters = ", ".join(f"{k} = {v}" for k, v in c["parameters"].items())
        rows.append(dict(architecture=c["architecture"], kind="found", name=c["family"],
                         family="grammar" if c["grammar"] else "lobe", expression=f"{c['expression']}; {parameters}",
                         cycles=c["cycles"], cycles_predicted=c["cycles_predicted"], max_rel_error=c["d"],
                         on_front=c["on_front"], source="lobe_search", range=f"n in [{c['n_range'][0]:g}, {c['n_range'][1]:g}]",
                         parameter_per="material", d_line=c["d_line"], D=c["D"], D_line=c["D_line"],
                         admissible=c["admissible"]))
    for p in search.get("placements", []):
        rows.append(dict(architecture=p["architecture"], kind="anchor", name=p["lobe"], family="registry",
                         expression=p["label"], cycles=p["cycles"], max_rel_error=p["d"], on_front=p["on_front"],
                         source="optics.registry", range=f"n in [{p['n_range'][0]:g}, {p['n_range'][1]:g}]",
                         parameter_per="material", D=p["D"], dominated_by=p["dominated_by"]))
    return rows


def front_markdown(reg) -> str:
    rows = ["| terms | expression | RMS on the sample | RMS on every n |", "|---|---|---|---|",
            f"| 1 | {reg['constant_model']:.6g} (sample mean) | {reg['constant_model_rms']:.6g} | |"]
    for m in reg["front"]:
        rows.append(f"| {len(m['terms'])} | {m['expression']} | {m['rms']:.6g} | {m['rms_all_n']:.6g} |")
    return "\n".join(rows)
