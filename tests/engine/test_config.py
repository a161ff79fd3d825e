import subprocess
import sys

import pytest

from pipeline.engine import paths
from pipeline.engine.config import ConfigError, load_config, parse_override

from ..helpers import cli_env

BAD = [
    ("derivation.Q=1.5", r"'derivation.Q' = 1.5 is not allowed: expected a number in \(0, 1\), \"scan\" or \"optimize\""),
    ("derivation.Q=0", r"'derivation.Q' = 0 is not allowed"),
    ("derivation.n_min=0", r"'derivation.n_min' = 0 is not allowed: expected an integer >= 1"),
    ("derivation.n_max=2", r"'derivation.n_max' = 2 is not allowed: expected an integer > derivation.n_min = 2"),
    ("derivation.n_min=2.5", r"'derivation.n_min' = 2.5 is not allowed: expected an integer >= 1"),
    ("derivation.n_max=true", r"'derivation.n_max' = True is not allowed"),
    ("solver.rtol=-1e-9", r"'solver.rtol' = -1e-09 is not allowed: expected a number in \[1e-15, 1e-3\]"),
    ("derivation.metric=max", r"'derivation.metric' = 'max' is not allowed"),
    ("derivation.speed=3", r"config key 'derivation.speed' is unknown: allowed keys in \[derivation\] are n_min"),
    ("derivation.Q=0.5", r"'derivation.constants' = 'paper' is not allowed: expected \"fitted\""),
    ("regression.library=[\"n\"]", r"'regression.library' = \['n'\] is not allowed"),
]


@pytest.mark.parametrize("override,message", BAD)
def test_bad_values_name_the_key_the_value_and_what_is_allowed(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(paths.PAPER_CONFIG, (override,))


def test_set_without_equals_sign():
    with pytest.raises(ConfigError, match=r"--set 'derivation.Q' is not allowed: expected KEY=VALUE"):
        parse_override("derivation.Q")


def test_set_values_are_toml_literals_or_bare_strings():
    assert parse_override("derivation.Q=0.5") == ("derivation.Q", 0.5)
    assert parse_override("derivation.Q=optimize") == ("derivation.Q", "optimize")
    assert parse_override('derivation.constants="fitted"') == ("derivation.constants", "fitted")
    assert parse_override("zone.sensitivity_levels=[0.5, 0.6]") == ("zone.sensitivity_levels", [0.5, 0.6])


def test_negative_tolerance_in_an_expectation(tmp_path):
    text = paths.PAPER_CONFIG.read_text().replace("tolerance = 5e-4\nreason = \"printed to 3 decimals\"\n",
                                                  "tolerance = -5e-4\nreason = \"printed to 3 decimals\"\n", 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ConfigError, match=r"'expectations.P5_slope.tolerance' = -0.0005 is not allowed: expected a number >= 0"):
        load_config(bad)


def test_unknown_section_and_broken_toml(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[derivaton]\nQ = 0.5\n")
    with pytest.raises(ConfigError, match=r"config section '\[derivaton\]' is unknown"):
        load_config(bad)
    bad.write_text("[derivation\n")
    with pytest.raises(ConfigError, match="is not valid TOML"):
        load_config(bad)


def run_cli(args, tmp_path):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=paths.ROOT)


@pytest.mark.parametrize("args,message", [
    (["refit", "--config", "configs/paper.toml", "--set", "derivation.Q=1.5", "--out", "x"], "'derivation.Q' = 1.5"),
    (["refit", "--config", "configs/paper.toml", "--set", "derivation.Q", "--out", "x"], "expected KEY=VALUE"),
    (["refit", "--config", "configs/paper.toml"], "'run.name' = 'paper' is not allowed for a refit"),
    (["refit", "--config", "configs/missing.toml"], "config file 'configs/missing.toml' does not exist"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(args, message, tmp_path):
    proc = run_cli(args, tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert proc.stderr.count("\n") == 1          # one message
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()


def test_the_config_reference_lists_every_config_key_as_pipeline_keys_does():
    """docs/reference/config.md is generated from the same table (`make docs`; tests/docs checks it is
    not stale)."""
    from pipeline.engine import paths
    from pipeline.engine.config import SCHEMA
    page = (paths.ROOT / "docs" / "reference" / "config.md").read_text()
    assert all(f"| `{k.name}` |" in page for k in SCHEMA)


# The extremes a user can type, of every type: what TOML and `--set` let through.
EXTREMES = ("0", "-1", "1", "2", "4294967294", "4294967295", "9223372036854775805", "9223372036854775807",
            "18446744073709551616", "1000000000000000000000000000000", "-1000000000000000000000000000000",
            "1e-300", "1e300", "-1e300", "0.0", "nan", "inf", "-inf", "true", '""', '"' + "x" * 10_000 + '"',
            "[]", "[" + ", ".join(["1"] * 100_000) + "]", "[1000000000000000000000000000000]", "[1e300]",
            "[0.5]", "[2, 3]")


COMBINED = ("derivation.constants", "derivation.n_max", "paper_model.intercept", "paper_model.coef_offset",
            "mitsuba.spp", "sample.consecutive_to/spread_from", "sample.spread_count", "scan.fine_step",
            "albedo.curve_n", "regression.threshold_max")


def test_every_key_at_its_extremes_is_answered_in_bounded_time_and_what_passes_has_bounded_sizes():
    """Each key of the schema gets each extreme value: the validator answers (a Config or a
    ConfigError naming the key) within a second, and where it accepts, the sizes the stages build
    from it are bounded: the sample, the Q grids, the Mitsuba render's sample count."""
    import time

    import numpy as np

    import tomllib

    from pipeline.engine.config import MITSUBA_SAMPLES_MAX, SCHEMA, _flatten, validate
    from pipeline.stages.common import sample_exponents
    # The paper's config read once; each extreme as `--set` would give it (the file's expectations
    # are left out: they are checked by the tests above, and not what an extreme value changes).
    base = _flatten(tomllib.loads(paths.PAPER_CONFIG.read_text()))[0] | {"derivation.constants": "fitted"}
    values = {text: parse_override(f"x={text}")[1] for text in EXTREMES}
    accepted = 0
    for key in SCHEMA:
        for text in EXTREMES:
            start = time.perf_counter()
            try:
                config = validate(base | {key.name: values[text]}, {}, "paper.toml")
            except ConfigError as e:
                # It names this key, or the key of the combination it breaks (a sample, an n range
                # that the paper's constants no longer hold for, a Mitsuba sample count).
                named = str(e).split("'")[1]
                assert key.name.split(".", 1)[1] in named or named in COMBINED, (key.name, text[:40], str(e)[:200])
            else:
                accepted += 1
                assert len(sample_exponents(config)) <= 100_000
                assert 1 / config["scan.coarse_step"] <= 1000
                assert 2 * config["scan.coarse_step"] / config["scan.fine_step"] <= 2000
                spp = max(config["mitsuba.spp"], config["mitsuba.fallback_spp"])
                assert config["mitsuba.width"] * config["mitsuba.height"] * spp <= MITSUBA_SAMPLES_MAX
                assert np.isfinite(config["paper_model.slope"] * config["derivation.n_max"])
            assert time.perf_counter() - start < 1.0, (key.name, text[:40])
    assert accepted > 0


@pytest.mark.parametrize("override,message", [
    ("sample.spread_count=1000000000000000000000000000000", "at most n_max - spread_from \\+ 1 = 927"),
    ("mitsuba.seed=4294967295", "expected an integer in \\[0, 2\\^32 - 2\\]"),
    ("albedo.mc_seed=9223372036854775806", "expected an integer in \\[0, 2\\^63 - 3\\]"),
    ("mitsuba.spp=128", "a power of 4"),
    ("scan.fine_step=0.00001", "scan.coarse_step / 1000"),
])
def test_values_that_used_to_hang_or_crash_are_refused_by_arithmetic(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(paths.PAPER_CONFIG, (override,))


def test_the_largest_seeds_allowed_are_what_the_libraries_take():
    """The largest mc_seed plus the stage's offsets (+1, +2) is a JAX PRNG seed; one more is not."""
    from pipeline.engine.config import JAX_SEED_MAX
    from pipeline.optics.numerics import jax
    jax.random.PRNGKey(JAX_SEED_MAX + 2)
    with pytest.raises(OverflowError):
        jax.random.PRNGKey(JAX_SEED_MAX + 3)


@pytest.mark.parametrize("text, key", [("lobe.power=1", "lobe.power"), ("lobe.power=17", "lobe.power"),
                                       ("lobe.power=2.5", "lobe.power"), ("lobe.power=true", "lobe.power"),
                                       ("front.powers=[]", "front.powers"), ("front.powers=[2, 17]", "front.powers"),
                                       ("front.powers=[3, 3]", "front.powers")])
def test_bad_powers_are_refused_naming_the_key(text, key):
    from pipeline.engine.config import ConfigError
    with pytest.raises(ConfigError, match=rf"'{key}'.*expected .*\[2, 16\]"):
        load_config(paths.ROOT / "configs" / "power_4.toml", (text,))
