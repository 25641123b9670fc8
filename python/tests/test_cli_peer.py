"""Python against the command line (the peer): the same fits bit for bit, the same f_r, the same
error messages. Both run brdfit's library, so any difference is the binding's: options
translated differently, a number converted on the way, a message lost."""

import json
import math
import re

import numpy as np
import pytest

import brdfit
from conftest import run

DATA = ["blinn-mgo.csv", "blinn-aluminium.csv", "merl-alumina-oxide.csv", "merl-aluminium.csv", "cayman.astm"]

# Measured times: the only fields that differ between two runs of the same fit.
TIMES = re.compile(r'^\s*"(seconds|geometry_seconds|solve_seconds|statistics_seconds)": .*$\n', re.M)


def without_times(text: str) -> str:
    return TIMES.sub("", text)


@pytest.mark.parametrize("name", DATA)
def test_fit_all_equals_cli_json(cli, root, tmp_path, name):
    """fit --model all --verify 2 of every bundled file: the same JSON text, character for
    character, but for the measured times (which are there in both)."""
    path = root / "data" / name
    out = tmp_path / "cli.json"
    run(cli, "fit", str(path), "--model", "all", "--verify", "2", "--json", str(out))
    expected = out.read_text(encoding="utf-8")
    fits = brdfit.fit_all(brdfit.load(path), verify=2)
    got = brdfit.to_json(fits)
    assert got.count('"seconds"') == expected.count('"seconds"') > 0
    assert without_times(got) == without_times(expected)


@pytest.mark.parametrize(
    "name, flags, options",
    [
        ("blinn-mgo.csv", [], {}),
        ("merl-aluminium.csv", ["--model", "ggx-smith", "--loss", "linear", "--verify", "3"],
         {"model": "ggx-smith", "loss": "linear", "verify": 3}),
        ("merl-alumina-oxide.csv", ["--distribution", "d1", "--fix", "n=1.5", "--max-theta", "70"],
         {"distribution": "d1", "fix": {"n": 1.5}, "max_theta": 70.0}),
        ("merl-alumina-oxide.csv", ["--shared", "n,c3", "--weights", "solid-angle"],
         {"shared": ["n", "c3"], "weights": "solid-angle"}),
    ],
)
def test_fit_options_equal_cli(cli, root, tmp_path, name, flags, options):
    """One model with options spelt as the flags: the same JSON as the command line's."""
    path = root / "data" / name
    out = tmp_path / "cli.json"
    run(cli, "fit", str(path), *flags, "--json", str(out))
    model = options.pop("model", "torrance-sparrow")
    r = brdfit.fit(brdfit.load(path), model=model, **options)
    assert without_times(brdfit.to_json(r)) == without_times(out.read_text(encoding="utf-8"))


def test_fit_channel_and_arrays_equal_file(cli, root, tmp_path):
    """A channel picked at loading, and the same samples given as arrays: the same fit as the
    command line's --channel g."""
    path = root / "data" / "merl-aluminium.csv"
    out = tmp_path / "cli.json"
    run(cli, "fit", str(path), "--channel", "g", "--json", str(out))
    expected = without_times(out.read_text(encoding="utf-8"))
    g = brdfit.load(path, channel="g")
    assert without_times(brdfit.fit(g).to_json()) == expected
    arrays = brdfit.fit((g.directions, g.values[:, 0]), model="torrance-sparrow")
    # The arrays' channel is named brdf, not g: the rest is the same.
    assert without_times(arrays.to_json()).replace('"channel": "brdf"', '"channel": "g"') == expected


def directions(n, seed):
    """Seeded directions over the upper hemisphere (θ < 88°), φi and φo anywhere."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, math.radians(88), size=(n, 2))
    p = rng.uniform(-math.pi, math.pi, size=(n, 2))
    return np.column_stack([t[:, 0], p[:, 0], t[:, 1], p[:, 1]])


@pytest.mark.parametrize(
    "model, dist, params",
    [
        ("torrance-sparrow", "d3", {"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}),
        ("torrance-sparrow", "d1", {"n": 200.0, "c1": 12.0, "ps": 0.4, "pd": 0.6}),
        ("phong", None, {"c1": 30.0, "ps": 0.5, "pd": 0.2}),
        ("ggx-smith", None, {"alpha": 0.2, "n": 1.5, "ps": 1.0, "pd": 0.1}),
    ],
)
def test_eval_equals_cli(cli, tmp_path, model, dist, params):
    """eval at 500 seeded directions equals brdfit eval on a CSV of the same directions (in
    radians, written with Python's round-trip repr), value for value."""
    d = directions(500, 7)
    dirs = tmp_path / "dirs.csv"
    dirs.write_text(
        "theta_i_rad,phi_i_rad,theta_o_rad,phi_o_rad\n"
        + "".join(",".join(repr(float(x)) for x in row) + "\n" for row in d)
    )
    out = tmp_path / "out.csv"
    setting = ",".join(f"{k}={v!r}" for k, v in params.items())
    flags = ["--distribution", dist] if dist else []
    run(cli, "eval", "--model", model, *flags, "--set", setting, str(dirs), "-o", str(out))
    lines = [l for l in out.read_text().splitlines() if not l.startswith("#")]
    col = lines[0].split(",").index("brdf")
    expected = np.array([float(l.split(",")[col]) for l in lines[1:]])
    got = brdfit.eval(model, params, d, distribution=dist)
    assert got.shape == (500,)
    np.testing.assert_array_equal(got, expected)
    # Not contiguous (every other row, Fortran order): the same values.
    np.testing.assert_array_equal(brdfit.eval(model, params, d[::2], distribution=dist), expected[::2])
    np.testing.assert_array_equal(brdfit.eval(model, params, np.asfortranarray(d), distribution=dist), expected)


def test_eval_lambert_is_pd_over_pi():
    """Worked by hand: Lambert's f_r is pd/π at every direction."""
    got = brdfit.eval("lambert", {"pd": 0.5}, directions(50, 3))
    np.testing.assert_allclose(got, 0.5 / math.pi, rtol=1e-15)


def cli_error(cli, *args):
    p = run(cli, *args, check=False)
    assert p.returncode == 1, p.stderr
    first = p.stderr.split("\n  on the command line:")[0].rstrip("\n")
    assert first.startswith("error: ")
    return first[len("error: "):]


def test_errors_carry_the_cli_message(cli, root, tmp_path):
    """Bad input raises BrdfitError with the message the command line prints after `error: `."""
    missing = tmp_path / "missing.csv"
    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.load(missing)
    assert str(e.value) == cli_error(cli, "info", str(missing))

    bad = tmp_path / "bad.csv"
    bad.write_text("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n10,0,20,180,0.5\n10,0,95,180,abc\n")
    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.load(bad)
    assert str(e.value) == cli_error(cli, "info", str(bad))
    assert "line 3" in str(e.value) or ":3" in str(e.value)

    negative = tmp_path / "negative.csv"
    negative.write_text("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n10,0,20,180,-0.5\n")
    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.load(negative, negative="error")
    assert str(e.value) == cli_error(cli, "info", str(negative), "--negative", "error")

    mgo = root / "data" / "blinn-mgo.csv"
    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.load(mgo, channel="g")
    assert str(e.value) == cli_error(cli, "fit", str(mgo), "--channel", "g")

    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.eval("phong", {"n": 30.0, "ps": 0.5}, directions(3, 1))
    assert str(e.value) == cli_error(cli, "eval", "--model", "phong", "--set", "n=30,ps=0.5", str(mgo))

    with pytest.raises(brdfit.BrdfitError) as e:
        brdfit.fit(brdfit.load(mgo), model="torrance-sparrow", shared=["q"])
    assert str(e.value) == cli_error(cli, "fit", str(mgo), "--shared", "q").removeprefix(f"{mgo}: ")


def test_bad_choices_raise():
    """A misspelt choice names the valid ones."""
    with pytest.raises(brdfit.BrdfitError, match="torrance-sparrow"):
        brdfit.eval("torrance-sparow", {}, directions(1, 1))
    with pytest.raises(brdfit.BrdfitError, match="flip_p99"):
        brdfit.choose(brdfit.simulate("lambert", {"pd": 0.5}, grid="hemisphere:100"), threshold="flip_p98=0.05")
    with pytest.raises(brdfit.BrdfitError, match=r"\(N, 4\)"):
        brdfit.eval("lambert", {"pd": 0.5}, np.zeros((3, 3)))


def test_nbrdf_simulate_equals_cli(cli, root, tmp_path):
    """A network sampled on the goniometer grid: the command line's CSV holds the same values
    (written as shortest round-trip decimals) at the same directions (written in degrees)."""
    w = root / "tests" / "data" / "nbrdf" / "weights-merl8.json"
    out = tmp_path / "net.csv"
    run(cli, "simulate", "--nbrdf", str(w), "--material", "steel", "--grid", "goniometer", "-o", str(out))
    expected = brdfit.load(out)
    got = brdfit.simulate(nbrdf=w, material="steel", grid="goniometer")
    np.testing.assert_array_equal(got.values, expected.values)
    np.testing.assert_allclose(got.directions, expected.directions, rtol=0, atol=1e-12)
