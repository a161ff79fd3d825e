"""The report's readings are rules on the numbers: planted numbers flip them."""

from pipeline.publish import report_beyond


def test_the_monte_carlo_rerun_reading_follows_its_numbers():
    tail = dict(rerun_z=[0.1] * 16, rerun_mean_z=0.2, rerun_std_z=1.1)
    assert report_beyond._rerun_reading(tail).startswith("consistent with a tail event")
    for planted in (dict(tail, rerun_mean_z=2.0), dict(tail, rerun_std_z=3.0)):
        assert report_beyond._rerun_reading(planted).startswith("not what an unbiased estimator")


def test_the_shipped_render_reading_follows_the_coef_ratio():
    row = dict(scene="sphere", n=10.0, coef=1.0, coef_over_reference=1.2, flip_highlight=0.2,
               equal_peak_flip_highlight=0.1)
    s = dict(scenes=["sphere"], shipped_statistics=[row])
    assert "gets a brighter highlight centre" in report_beyond.shipped_text(s)
    assert "larger than at equal peak in 1 of 1" in report_beyond.shipped_text(s)
    s = dict(scenes=["sphere"], shipped_statistics=[dict(row, coef_over_reference=0.8, flip_highlight=0.05)])
    assert "gets a dimmer highlight centre" in report_beyond.shipped_text(s)
    assert "larger than at equal peak in 0 of 1" in report_beyond.shipped_text(s)


def test_the_ndf_reading_names_the_table_s_winners():
    rows = [dict(use="ndf", n_per="material", precision="fp32", architecture="rdna3", n_range=[2.0, 10.0],
                 winner="GGX"),
            dict(use="ndf", n_per="material", precision="fp32", architecture="gcn5", n_range=[2.0, 10.0], winner="")]
    text = report_beyond.ndf_decision_text(dict(decision=dict(available=True, table=rows)))
    assert "GGX (rdna3 2-10)" in text and "nothing (gcn5 2-10)" in text


def test_the_tools_section_names_each_tool_its_version_and_what_a_missing_one_costs():
    from pipeline.publish.report import tools_section

    doc = {"toolchains": {"llvm": {"path": "/lib/libLLVM.so.19.1", "version": "19", "missing": ""},
                          "radv": {"path": "", "version": "", "missing": "Mesa's RADV driver is not installed"}},
           "stages": {"mitsuba_render": {"variant": "llvm_ad_rgb"}}}
    lines = tools_section(doc)
    assert "- LLVM, for Mitsuba's llvm_ad_rgb variant (Dr.Jit): LLVM 19, `/lib/libLLVM.so.19.1`" in lines
    assert "- Mesa's RADV, for AMD machine code (Vulkan ICD): not usable: Mesa's RADV driver is not installed" in lines
    assert lines[-1] == "- Mitsuba variant: llvm_ad_rgb (mitsuba_render)"
