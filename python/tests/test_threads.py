"""The GIL is released while brdfit works: another Python thread runs during a fit, a choose and
a render. The switch interval is raised so far that no thread is ever made to hand over the GIL:
the counting thread (which hands it back at each step) can then run during the call only if the
call itself releases the GIL. Held through the call, the count does not move at all."""

import sys
import threading
import time

import pytest

import brdfit


def count_during(call):
    """Steps a second thread took while `call` ran in this thread."""
    state = {"n": 0, "stop": False}

    def counter():
        while not state["stop"]:
            state["n"] += 1
            time.sleep(0)  # releases the GIL: this thread never holds it for long

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e6)
    t = threading.Thread(target=counter)
    t.start()
    try:
        while state["n"] == 0:
            time.sleep(0.001)
        before = state["n"]
        result = call()
        during = state["n"] - before
    finally:
        state["stop"] = True
        t.join()
        sys.setswitchinterval(old)
    return during, result


def test_a_call_holding_the_gil_stops_the_counter():
    """The test's own check: a pure Python loop (which holds the GIL) leaves the count where it was."""
    during, _ = count_during(lambda: sum(i * i for i in range(2_000_000)))
    assert during == 0


def test_fit_releases_the_gil(root):
    data = brdfit.load(root / "data" / "merl-alumina-oxide.csv", channel="g")
    during, fits = count_during(lambda: brdfit.fit_all(data, verify=2))
    assert len(fits) == 9
    assert during > 0


def test_choose_releases_the_gil(root):
    data = brdfit.load(root / "data" / "blinn-mgo.csv")
    during, answer = count_during(lambda: brdfit.choose(data, res=64, verify=0))
    assert [c["case"] for c in answer["cases"]] == ["front", "edge"]
    assert during > 0


@pytest.fixture
def scene(root, tmp_path):
    """The front-lit Mitsuba peer scene at 128 × 128."""
    text = (root / "data" / "scenes" / "mitsuba-front.toml").read_text()
    text = text.replace("width = 512", "width = 128").replace("height = 512", "height = 128")
    path = tmp_path / "front.toml"
    path.write_text(text)
    return path


def test_render_releases_the_gil(scene):
    with pytest.warns(UserWarning, match="directional albedo"):
        during, image = count_during(lambda: brdfit.render(scene))
    assert image.shape == (128, 128, 3) and str(image.dtype) == "float32"
    # Black background above the spheres, lit spheres across the middle row.
    assert image[0, 0].max() == 0.0
    assert image[64, 32:96].max() > 0.1
    assert during > 0
