"""Tests of the Python module: run with `pytest python/tests` after `pip install ./python`.

The command-line binary (target/release/lodestar, built by `cargo build --release`) is the
reference for bit-identical images; the furnace test has an exact answer.
"""

import os
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import lodestar

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "tests" / "data" / "tiny.toml"
CLI = ROOT / "target" / "release" / "lodestar"

# A 12 x 8 furnace: a diffuse sphere of albedo 1 in a constant environment; every pixel's
# expectation is the environment's radiance exactly.
FURNACE = """
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 40
resolution = [12, 8]

[render]
max_depth = 63
spp = 1

[[material]]
name = "white"
type = "diffuse"
albedo = [1, 1, 1]

[[shape]]
name = "ball"
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "white"

[[light]]
type = "environment"
radiance = [0.3, 0.5, 0.7]
"""


def test_render_returns_an_hwc_float32_image_and_stats():
    image, stats = lodestar.render(TINY, spp=2, seed=3, threads=1)
    assert image.shape == (16, 16, 3)
    assert image.dtype == np.float32
    assert image.flags["C_CONTIGUOUS"]
    assert np.isfinite(image).all() and image.mean() > 0
    assert stats["integrator"] == "pt"
    assert stats["spp"] == 2 and isinstance(stats["spp"], int)
    assert stats["seed"] == 3 and stats["threads"] == 1
    assert stats["seconds"] > 0


def test_same_image_as_the_command_line(tmp_path):
    assert CLI.exists(), f"{CLI} is missing: run `cargo build --release` first"
    out = tmp_path / "tiny.exr"
    subprocess.run(
        [CLI, "render", TINY, "--integrator", "bdpt", "--spp", "3", "--seed", "7",
         "--threads", "2", "--quiet", "-o", out],
        check=True,
    )
    cli = lodestar.read_exr(out)
    image, _ = lodestar.render(TINY, "bdpt", spp=3, seed=7, threads=1)
    np.testing.assert_array_equal(image, cli)


def test_seed_decides_the_image_and_threads_do_not():
    a, _ = lodestar.render(TINY, "guided-bdpt", spp=6, seed=1, threads=1)
    b, _ = lodestar.render(TINY, "guided-bdpt", spp=6, seed=1, threads=2)
    c, _ = lodestar.render(TINY, "guided-bdpt", spp=6, seed=2, threads=2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_scene_from_toml_text_matches_the_exact_furnace():
    # 256 samples of 96 pixels: the mean's standard error is under 1e-3 per channel (the
    # sphere's diffuse bounces are exact in expectation); 0.01 is > 10 sigma.
    image, stats = lodestar.render(FURNACE, spp=256, seed=0)
    assert image.shape == (8, 12, 3)
    np.testing.assert_allclose(image.reshape(-1, 3).mean(axis=0), [0.3, 0.5, 0.7], atol=0.01)
    assert stats["scene"] == "<scene text>"


def test_options_and_defines_reach_the_integrator_and_the_scene():
    _, stats = lodestar.render(TINY, "vcm", spp=1, options={"radius_alpha": 0.5, "merge": False})
    assert "alpha: 0.5" in stats["settings"] and "merge: false" in stats["settings"]
    xml = ROOT / "scenes" / "mitsuba" / "cornell-box.xml"
    small, stats = lodestar.render(xml, defines={"res": 20, "spp": 2, "max_depth": 3})
    assert small.shape == (20, 20, 3)
    assert stats["spp"] == 2


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(integrator="nope"), ["unknown integrator 'nope'", "guided-bdpt"]),
        (dict(spp=1, time=1.0), ["spp or time"]),
        (dict(spp=0), ["spp must be at least 1"]),
        (dict(options={"no_such_key": 1}), ["'no_such_key'", "not a setting"]),
        (dict(options={"rr_depth": "x"}), ["rr_depth", "expected"]),
        (dict(defines={"x": 1}), ["takes none"]),
    ],
)
def test_bad_arguments_raise_value_errors_naming_them(kwargs, words):
    scene = None if "defines" in kwargs else TINY
    with pytest.raises(ValueError) as e:
        lodestar.render(scene, **{"spp": 1, **kwargs})
    for w in words:
        assert w in str(e.value)


def test_a_missing_scene_file_names_it():
    with pytest.raises(ValueError, match="no-such-scene.toml"):
        lodestar.render("no-such-scene.toml", spp=1)


def test_progress_rises_to_one():
    seen = []
    lodestar.render(TINY, spp=40, progress=seen.append)
    assert seen and seen[-1] == 1.0 and seen.count(1.0) == 1
    assert all(0.0 <= p <= 1.0 for p in seen)
    assert seen == sorted(seen)


def test_an_exception_in_the_progress_callback_stops_the_render():
    class Enough(Exception):
        pass

    def stop(p):
        raise Enough()

    start = time.monotonic()
    with pytest.raises(Enough):
        lodestar.render(TINY, time=60.0, progress=stop)
    # It stopped after a pass, not after the 60 s budget.
    assert time.monotonic() - start < 30


def test_ctrl_c_stops_a_render_cleanly():
    # Python's own Ctrl-C handler, also where the test runner was started with SIGINT ignored
    # (a background job of a non-interactive shell, as CI may be).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            lodestar.render(TINY, "guided-pt", time=60.0)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 30
    # The module is usable afterwards.
    image, _ = lodestar.render(TINY, spp=1)
    assert image.shape == (16, 16, 3)


def test_the_gil_is_released_while_rendering():
    ticks = [0]
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks[0] += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        lodestar.render(TINY, time=0.5, threads=1)
    finally:
        done.set()
        t.join()
    # A thread that held no GIL for 0.5 s would count to 0; released, it counts to hundreds.
    assert ticks[0] > 50, ticks[0]


def test_compare_computes_the_errors():
    ref = np.ones((4, 5, 3), np.float32)
    img = np.full((4, 5, 3), 1.5, np.float32)
    c = lodestar.compare(img, ref)
    assert c["mse"] == pytest.approx(0.25)
    assert c["rmse"] == pytest.approx(0.5)
    assert c["rel_mse"] == pytest.approx(0.25 / 1.01)
    assert c["mean"] == pytest.approx([1.5, 1.5, 1.5])
    with pytest.raises(ValueError, match="H x W x 3"):
        lodestar.compare(np.ones((4, 5)), ref)
    with pytest.raises(ValueError):
        lodestar.compare(np.ones((4, 6, 3)), ref)


def test_exr_round_trip(tmp_path):
    a = np.random.default_rng(0).random((3, 7, 3), dtype=np.float32)
    lodestar.write_exr(tmp_path / "a.exr", a)
    np.testing.assert_array_equal(lodestar.read_exr(tmp_path / "a.exr"), a)


def test_integrators_lists_the_registry():
    names = [e["name"] for e in lodestar.integrators()]
    for n in ["pt", "lt", "bdpt", "vcm", "bpm", "pssmlt", "mmlt", "guided-pt", "guided-bdpt", "guided-vcm"]:
        assert n in names
    assert all(e["summary"] for e in lodestar.integrators())
    pt = next(e for e in lodestar.integrators() if e["name"] == "pt")
    rr = next(o for o in pt["options"] if o["name"] == "rr_depth")
    assert rr["default"] == "5"


def test_bench_returns_rows_for_each_run_and_the_medians(tmp_path):
    reference, _ = lodestar.render(TINY, "pt", spp=64, seed=99)
    lodestar.write_exr(tmp_path / "ref.exr", reference)
    seen = []
    rows = lodestar.bench(
        TINY, ["pt", "bdpt:mis=power"], time=0.2, reference=tmp_path / "ref.exr",
        runs=2, out=tmp_path / "bench", progress=seen.append,
    )
    # Four renders: progress moves by quarters (the callback sees what a poll finds), once 1.
    assert set(seen) <= {0.0, 0.25, 0.5, 0.75, 1.0}
    assert seen == sorted(seen) and seen[-1] == 1.0 and seen.count(1.0) == 1
    runs = [r for r in rows if not r["median"]]
    medians = [r for r in rows if r["median"]]
    assert [(r["integrator"], r["run"]) for r in runs] == [
        ("pt", 0), ("pt", 1), ("bdpt:mis=power", 0), ("bdpt:mis=power", 1)]
    assert [r["integrator"] for r in medians] == ["pt", "bdpt:mis=power"]
    assert all(r["mse"] > 0 and r["seconds"] > 0 for r in rows)
    assert (tmp_path / "bench").is_dir()
    # A Mitsuba scene's parameters: at res 8 the 8 x 8 reference fits.
    xml = ROOT / "scenes" / "mitsuba" / "cornell-box.xml"
    small, _ = lodestar.render(xml, "pt", spp=2, defines={"res": 8})
    lodestar.write_exr(tmp_path / "ref8.exr", small)
    rows8 = lodestar.bench(xml, ["pt"], time=0.05, reference=tmp_path / "ref8.exr", runs=1,
                           defines={"res": 8})
    assert rows8[0]["mse"] >= 0
    pandas = pytest.importorskip("pandas")
    frame = pandas.DataFrame(rows)
    assert set(frame.integrator) == {"pt", "bdpt:mis=power"}
