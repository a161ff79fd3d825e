"""The machine-code stage where the compiler cannot run: it says why, returns no rows, and the
report and the summary say "machine-code cost not measured", and nothing is decided (nothing fails)."""

from pipeline.engine import graph, toolchains
from pipeline.engine.cache import Memo
from pipeline.publish import report_beyond, summary
from pipeline.stages import decision, gpu_isa


def test_without_radv_the_stage_says_why_and_the_report_says_not_measured(monkeypatch, tmp_path, paper_run,
                                                                          paper_config):
    real = toolchains.locate
    monkeypatch.setattr(toolchains, "locate", lambda tool: toolchains.find_radv({}, (str(tmp_path),))
                        if tool == "radv" else real(tool))
    out = gpu_isa.run({"lobe.power": 2, "front.powers": [2, 3]}, {}, Memo(None))
    assert out["available"] is False and out["rows"] == []
    assert "mesa-vulkan-drivers" in out["reason"]
    r = dict(paper_run, gpu_isa=out)
    text = "\n".join(report_beyond.machine_code_section(None, r))
    assert "Machine-code cost not measured: " + out["reason"] in text
    stage = graph.BY_NAME["decision"]
    inputs = {path: r[path.split(".")[0]][path.split(".")[1]] for path in stage.inputs}
    d = decision.run(paper_config.subset(stage.reads), inputs, Memo(None))
    assert d["available"] is False and d["table"] == [] and d["reason"] == out["reason"]
    text = "\n".join(summary.lines(paper_config, dict(r, decision=d)))
    assert f"machine-code cost not measured ({out['reason']})" in text
    assert report_beyond.machine_row(r, "f_Q2") is None
