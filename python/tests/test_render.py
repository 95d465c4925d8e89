"""tsl.render against the EXR `tslc render` writes with the same settings."""

import subprocess

import numpy as np
import pytest

import tsl


def cli_render(tslc, scene, out, *args):
    subprocess.run([str(tslc), "render", str(scene), "-o", str(out), "-q", *args], check=True)
    return out


@pytest.mark.parametrize(
    "settings, cli",
    [
        (dict(spp=4, res=(40, 30), seed=3), ["--spp", "4", "--res", "40x30", "--seed", "3"]),
        (
            dict(spp=2, res=(24, 18), integrator="whitted", color="spectral"),
            ["--spp", "2", "--res", "24x18", "--integrator", "whitted", "--color", "spectral"],
        ),
    ],
)
def test_render_matches_the_cli_bit_for_bit(repo, tslc, tmp_path, settings, cli):
    scene = repo / "examples" / "cornell.tsl"
    image = tsl.render(str(scene), **settings)
    width, height = settings["res"]
    assert image.shape == (height, width, 3) and image.dtype == np.float32
    assert image.mean() > 0.01
    exr = tsl.read_exr(cli_render(tslc, scene, tmp_path / "cli.exr", *cli))
    np.testing.assert_array_equal(image.view(np.uint32), exr.view(np.uint32))


def test_aov_layers_match_the_cli(repo, tslc, tmp_path):
    scene = repo / "examples" / "cornell.tsl"
    image, layers = tsl.render(scene, spp=2, res=(20, 16), aov=True)
    assert set(layers) == {"albedo", "normal", "depth", "object"}
    assert layers["depth"].shape == (16, 20) and layers["object"].dtype == np.int32
    cli_image, cli_layers = tsl.read_exr(
        cli_render(tslc, scene, tmp_path / "aov.exr", "--spp", "2", "--res", "20x16", "--aov"), aov=True
    )
    np.testing.assert_array_equal(image, cli_image)
    for name in ("albedo", "normal", "depth"):
        np.testing.assert_array_equal(layers[name], cli_layers[name], err_msg=name)


def test_render_errors(repo, tmp_path):
    broken = tmp_path / "broken.tsl"
    broken.write_text("scene { camera { } }\nmaterial m = lamberd;\n")
    with pytest.raises(tsl.CompileError) as caught:
        tsl.render(broken)
    assert any(d.file.endswith("broken.tsl") for d in caught.value.diagnostics)
    no_scene = tmp_path / "no_scene.tsl"
    no_scene.write_text("material m = lambert;\n")
    with pytest.raises(tsl.CompileError, match="no `scene"):
        tsl.render(no_scene)
    with pytest.raises(ValueError, match="not an integrator"):
        tsl.render(repo / "examples" / "cornell.tsl", integrator="bdpt")
    with pytest.raises(ValueError, match="not a color model"):
        tsl.render(repo / "examples" / "cornell.tsl", color="cmyk")
    with pytest.raises(ValueError, match="spp must be"):
        tsl.render(repo / "examples" / "cornell.tsl", spp=0)


def test_ctrl_c_cancels_a_render(repo):
    import os
    import signal
    import threading
    import time

    # A shell that starts pytest in the background leaves SIGINT ignored,
    # and Python then keeps it ignored: install Python's own handler.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        # About a minute of work in a debug build; cancelled within a row.
        with pytest.raises(KeyboardInterrupt):
            tsl.render(repo / "examples" / "cornell.tsl", spp=256, res=(160, 120))
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.perf_counter() - start < 10


def test_progress_is_reported_and_its_exceptions_stop_the_render(repo):
    seen = []
    image = tsl.render(repo / "examples" / "cornell.tsl", spp=2, res=(32, 24), progress=lambda d, t: seen.append((d, t)))
    assert image.shape == (24, 32, 3)
    assert seen and seen[-1] == (32 * 24, 32 * 24)
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))

    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop(f"{done} of {total}")

    with pytest.raises(Stop):
        tsl.render(repo / "examples" / "cornell.tsl", spp=256, res=(160, 120), progress=stop)
