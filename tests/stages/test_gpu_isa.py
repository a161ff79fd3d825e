"""The machine-code stage where a compiler cannot run: without any, it says why, returns no rows,
the report and the summary say "machine-code cost not measured", and nothing is decided (nothing
fails); without one vendor's, the others' rows are there, the report says which vendor is missing
and why, and the decision covers the others."""

import pytest

from pipeline.engine import graph, toolchains
from pipeline.engine.cache import Memo
from pipeline.publish import report_beyond, summary
from pipeline.stages import decision, gpu_isa


def absent(monkeypatch, tmp_path, tools):
    real = toolchains.locate
    missing = {"radv": toolchains.find_radv({}, (str(tmp_path),)),
               "nvidia": toolchains.Found("nvidia", None, "", "", "ptxas, cuobjdump, nvdisasm not found: NVIDIA "
                                          "machine code is not measured; " + toolchains.NVIDIA_INSTALL),
               "intel": toolchains.Found("intel", None, "", "", "ocloc not found: Intel machine code is not "
                                         "measured; " + toolchains.INTEL_INSTALL),
               "mesa_mobile": toolchains.find_mesa_mobile({"PATH": str(tmp_path)})}
    monkeypatch.setattr(toolchains, "locate", lambda tool: missing[tool] if tool in tools else real(tool))


def decide(r, paper_config):
    stage = graph.BY_NAME["decision"]
    inputs = {path: r[path.split(".")[0]][path.split(".")[1]] for path in stage.inputs}
    return decision.run(paper_config.subset(stage.reads), inputs, Memo(None))


def test_without_any_compiler_the_stage_says_why_and_the_report_says_not_measured(monkeypatch, tmp_path, paper_run,
                                                                                  paper_config):
    absent(monkeypatch, tmp_path, ("radv", "nvidia", "intel", "mesa_mobile"))
    out = gpu_isa.run({"lobe.power": 2, "front.powers": [2, 3]}, {}, Memo(None))
    assert out["available"] is False and out["rows"] == []
    assert all(name in out["reason"] for name in ("mesa-vulkan-drivers", "nvidia-cuda-nvcc-cu12", "intel-opencl-icd",
                                                  "install-mesa-arm64.sh"))
    r = dict(paper_run, gpu_isa=out)
    text = "\n".join(report_beyond.machine_code_section(None, r))
    assert "Machine-code cost not measured: " + out["reason"] in text
    d = decide(r, paper_config)
    assert d["available"] is False and d["table"] == [] and d["reason"] == out["reason"]
    text = "\n".join(summary.lines(paper_config, dict(r, decision=d)))
    assert f"machine-code cost not measured ({out['reason']})" in text
    assert report_beyond.machine_row(r, "f_Q2") is None


def test_without_radv_the_other_vendor_is_measured_and_decided(monkeypatch, tmp_path, paper_run, paper_config):
    if not toolchains.locate("nvidia").found:
        pytest.skip(f"NVIDIA machine code not measured here: {toolchains.locate('nvidia').missing}")
    absent(monkeypatch, tmp_path, ("radv",))
    out = gpu_isa.run({"lobe.power": 2, "front.powers": [2, 3]}, {}, Memo(None))
    others = {"nvidia"} | ({"intel"} if toolchains.locate("intel").found else set()) \
        | ({"qualcomm", "arm"} if toolchains.locate("mesa_mobile").found else set())
    assert out["available"] is True and {r["vendor"] for r in out["rows"]} == others
    assert "mesa-vulkan-drivers" in out["missing"]["amd"]
    r = dict(paper_run, gpu_isa=out)
    text = "\n".join(report_beyond.machine_code_section(None, r))
    assert f"- AMD: not measured here: {out['missing']['amd']}." in text and "\nNVIDIA:\n" in text
    d = decide(r, paper_config)
    assert d["available"] and {row["architecture"] for row in d["table"]} == set(out["devices"])
    answer = [line for line in summary.lines(paper_config, dict(r, decision=d)) if line.startswith("| ")]
    assert not any(line.startswith("| AMD") for line in answer) and any(line.startswith("| NVIDIA") for line in answer)
