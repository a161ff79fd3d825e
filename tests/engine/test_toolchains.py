"""The outside tools, found by the pipeline itself: the newest LLVM >= 15 in the library folders
(the user's DRJIT_LIBLLVM_PATH kept), Mesa's RADV and its version from the driver's own bytes, a
warning naming the install where one is missing, and cache keys that change with what was found
(a result computed without a tool is not reused once it is installed)."""

import os

import pytest

from pipeline.engine import graph, toolchains
from pipeline.engine.cache import Memo
from pipeline.engine.config import load_config
from pipeline.engine.paths import PAPER_CONFIG
from pipeline.runner import key_of


def touch(folder, *names, link=None):
    for name in names:
        (folder / name).write_bytes(b"")
    for name, target in (link or {}).items():
        os.symlink(folder / target, folder / name)


def test_the_newest_llvm_of_at_least_15_is_taken_with_its_links_followed(tmp_path):
    # Debian 12 with libllvm19 installed: 14 and 15 beside it, two names for 19.
    touch(tmp_path, "libLLVM-14.so.1", "libLLVM-15.so.1", "libLLVM.so.19.1",
          link={"libLLVM-14.so": "libLLVM-14.so.1", "libLLVM-19.so": "libLLVM.so.19.1"})
    candidates = toolchains.llvm_candidates((str(tmp_path),))
    assert [v for v, _ in candidates] == [19, 15, 14]
    found = toolchains.find_llvm({}, (str(tmp_path),))
    assert found.found and found.version == "19" and os.path.realpath(found.path) == str(tmp_path / "libLLVM.so.19.1")
    assert found.how == f"found in {tmp_path}"


def test_a_version_is_read_from_the_file_name_or_its_folder():
    assert toolchains.llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1") == 19
    assert toolchains.llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1") == 15
    assert toolchains.llvm_version("/usr/lib/llvm-14/lib/libLLVM.so") == 14
    assert toolchains.llvm_version("/usr/lib/libLLVM.so") is None


def test_only_an_older_llvm_is_missing_with_the_install_that_fixes_it(tmp_path):
    touch(tmp_path, "libLLVM-14.so.1")
    found = toolchains.find_llvm({}, (str(tmp_path),))
    assert not found.found
    assert "no LLVM >= 15 found (older: LLVM 14" in found.missing and "apt-get install libllvm19" in found.missing
    assert "scalar_rgb" in found.missing


def test_the_user_s_variable_is_kept_and_a_wrong_one_is_said(tmp_path):
    touch(tmp_path, "libLLVM.so.19.1", "libLLVM-17.so.1")
    mine = str(tmp_path / "libLLVM-17.so.1")
    found = toolchains.find_llvm({"DRJIT_LIBLLVM_PATH": mine}, (str(tmp_path),))
    assert found.path == mine and found.version == "17" and "set by the user" in found.how
    wrong = toolchains.find_llvm({"DRJIT_LIBLLVM_PATH": str(tmp_path / "nothing.so")}, (str(tmp_path),))
    assert not wrong.found and "nothing.so is not a file" in wrong.missing
    # An older LLVM chosen by the user is kept (Dr.Jit loads it), and said to be too old.
    touch(tmp_path, "libLLVM-14.so.1")
    old = toolchains.find_llvm({"DRJIT_LIBLLVM_PATH": str(tmp_path / "libLLVM-14.so.1")}, (str(tmp_path),))
    assert old.path == str(tmp_path / "libLLVM-14.so.1") and not old.found
    assert "is LLVM 14, older than 15" in old.missing
    assert f"LLVM 19 is installed: unset DRJIT_LIBLLVM_PATH or set it to {tmp_path}/libLLVM.so.19.1" in old.missing


def test_prepare_sets_drjit_s_variable_unless_the_user_set_it(monkeypatch, tmp_path):
    touch(tmp_path, "libLLVM.so.19.1")
    found = toolchains.find_llvm({}, (str(tmp_path),))
    monkeypatch.setattr(toolchains, "locate", lambda tool: found)
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "")     # (recorded, so that the test leaves the variable as it was)
    toolchains.prepare()
    assert os.environ["DRJIT_LIBLLVM_PATH"] == found.path
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/elsewhere/libLLVM.so.18")
    toolchains.prepare()
    assert os.environ["DRJIT_LIBLLVM_PATH"] == "/elsewhere/libLLVM.so.18"


def test_radv_is_found_with_mesa_s_version_from_the_driver(tmp_path):
    if not toolchains.find_radv({}, ()).missing.startswith("Mesa's RADV"):
        pytest.skip("no Vulkan loader here: RADV is reported missing before its ICD is looked for")
    driver = tmp_path / "libvulkan_radeon.so"
    driver.write_bytes(b"\0ELF...\0Mesa 23.1.9-1\0...")
    (tmp_path / "radeon_icd.x86_64.json").write_text(
        '{"ICD": {"api_version": "1.3.230", "library_path": "%s"}, "file_format_version": "1.0.0"}' % driver)
    found = toolchains.find_radv({}, (str(tmp_path),))
    assert found.found and found.version == "23.1.9" and found.path == str(tmp_path / "radeon_icd.x86_64.json")
    empty = tmp_path / "empty"
    empty.mkdir()
    missing = toolchains.find_radv({}, (str(empty),))
    assert not missing.found and "apt-get install mesa-vulkan-drivers libvulkan1" in missing.missing


def test_mesa_s_mobile_compilers_are_found_in_the_arm64_folder_with_their_version(tmp_path):
    """qemu-user on PATH and the arm64 user space (PIPELINE_MESA_ARM64): missing qemu, then a
    missing file of the user space, are said with the install; with both, Mesa's version is read
    from its gallium library's name."""
    bin_folder, root = tmp_path / "bin", tmp_path / "arm64"
    bin_folder.mkdir()
    environ = {"PATH": str(bin_folder), toolchains.MESA_ARM64_VARIABLE: str(root)}
    missing = toolchains.find_mesa_mobile(environ)
    assert missing.missing.startswith("qemu-aarch64-static not found") and "install-mesa-arm64.sh" in missing.missing
    qemu = bin_folder / "qemu-aarch64-static"
    qemu.write_text("#!/bin/sh\n")
    qemu.chmod(0o755)
    for name in toolchains.MESA_ARM64_FILES[:-1]:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_bytes(b"")
    lacking = toolchains.find_mesa_mobile(environ)
    assert f"the arm64 Mesa in {root} lacks usr/lib/aarch64-linux-gnu/dri" in lacking.missing and not lacking.found
    (root / toolchains.MESA_ARM64_FILES[-1]).mkdir()
    (root / "usr/lib/aarch64-linux-gnu/libgallium-25.0.7-2~bpo12+1.so").write_bytes(b"")
    found = toolchains.find_mesa_mobile(environ)
    assert found.found and found.version == "25.0.7-2~bpo12+1" and found.path == str(root)


def test_a_missing_tool_warns_in_one_line_and_a_found_one_not(monkeypatch, tmp_path):
    touch(tmp_path, "libLLVM-14.so.1")
    found = {"llvm": toolchains.find_llvm({}, (str(tmp_path),)),
             "radv": toolchains.Found("radv", "/icd.json", "22.3.6", "found in /")}
    monkeypatch.setattr(toolchains, "locate", found.__getitem__)
    lines = toolchains.warnings({"llvm", "radv"})
    assert len(lines) == 1 and lines[0].startswith("warning: no LLVM >= 15 found") and "\n" not in lines[0]
    assert toolchains.warnings({"radv"}) == [] and toolchains.warnings(()) == []


def test_keys_change_with_the_tool_found_and_only_for_what_runs_it(monkeypatch):
    """A stage or a memoized call that runs a tool is keyed on it: installing the tool recomputes
    it and nothing else."""
    config = load_config(str(PAPER_CONFIG))
    real = toolchains.locate

    def keys():
        return {name: key_of(graph.BY_NAME[name], config, {}) for name in ("zone", "gpu_isa")}

    def memo_key(fn):
        return Memo(None)._key("machine_code_registry", fn, {})[1]

    from pipeline.stages import gpu_isa, zone
    before, memo_before, plain_before = keys(), memo_key(gpu_isa.registry_rows), memo_key(zone.run)
    monkeypatch.setattr(toolchains, "locate", lambda tool: toolchains.Found("radv", None, "", "", "absent")
                        if tool == "radv" else real(tool))
    after = keys()
    assert after["zone"] == before["zone"] and after["gpu_isa"] != before["gpu_isa"]
    assert memo_key(gpu_isa.registry_rows) != memo_before and memo_key(zone.run) == plain_before
    assert graph.BY_NAME["mitsuba_render"].tools == ("llvm",)
    assert graph.BY_NAME["gpu_isa"].tools == ("radv", "nvidia", "intel", "mesa_mobile")


def test_an_unknown_tool_is_named():
    with pytest.raises(KeyError, match="unknown tool 'ptx'; the tools are llvm, radv, lavapipe, shader_tools, nvidia, intel, mesa_mobile"):
        toolchains.uses("ptx")


def test_the_report_names_every_tool():
    report = toolchains.report()
    assert set(report) == set(toolchains.FINDERS)
    for found in report.values():
        assert set(found) == {"path", "version", "missing"} and (found["path"] or found["missing"])


def test_a_run_says_at_its_start_which_tool_its_stages_lack(monkeypatch, tmp_path):
    """The machine-code stage without RADV: the run's first line names the install, once, and the
    stage's result says why AMD was not measured (NVIDIA's rows are there where ptxas is)."""
    from pipeline.engine.cache import Cache
    from pipeline.runner import run_stages

    real = toolchains.locate
    absent = toolchains.find_radv({}, (str(tmp_path),))
    monkeypatch.setattr(toolchains, "locate", lambda tool: absent if tool == "radv" else real(tool))
    config = load_config(str(PAPER_CONFIG))
    lines = []
    results, _, computed = run_stages(config, Cache(tmp_path / "cache"), lines.append, stages=("gpu_isa",))
    assert lines[0] == f"warning: {absent.missing}" and sum("warning" in s for s in lines) == 1, lines
    g = results["gpu_isa"]
    assert computed == ["gpu_isa"] and g["missing"]["amd"] == absent.missing
    others = {v for v, tool in (("nvidia", "nvidia"), ("intel", "intel"), ("qualcomm", "mesa_mobile"),
                                ("arm", "mesa_mobile")) if toolchains.locate(tool).found}
    assert g["available"] == bool(others) and {r["vendor"] for r in g["rows"]} == others
