# SPDX-License-Identifier: GPL-3.0-or-later
"""The comparison pictures (scripts/make_pictures.py): the generated Chess scene rendered
small in a child process must give a sheet of six tiles whose parts are the single tile
files, a FLIP mean in [0, 1] that is the benchmark's figure, a PROVENANCE tile with both
colours, and Cycles in the same orientation as Hybrid RT; a file-based scene without its
files must stop the run, naming the file, before anything is rendered.

Oracles: the benchmark's ``flip_mean`` (benchmarks/bench.py) for the FLIP convention,
OpenImageIO read straight from the tests (image_io.py) for the files written, the single tile
files for the sheet's layout.
"""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO_ROOT, load_addon

SCRIPT = REPO_ROOT / "scripts" / "make_pictures.py"
WIDTH, HEIGHT = 96, 54
DETAIL = 0.05  # ~95 k triangles: the whole run takes seconds
TILE_KEYS = ("hybrid", "full_bvh", "provenance", "flip", "eevee", "cycles")
# HYBRID against FULL_BVH at this size measured ~0.08; an image flipped or shifted against the
# other, or another scene, scores far above this bound.
SAME_SCENE_FLIP_MAX = 0.25
# Minimum spread (0..255) of a tile's bytes: a black, white or single-colour tile has none.
MIN_TILE_SPREAD = 40


@pytest.fixture(scope="module")
def pictures():
    """The script's module, imported as a library (its helpers need the add-on package)."""
    load_addon()
    import make_pictures

    return make_pictures


def read_png(path) -> np.ndarray:
    from image_io import read_png as read

    return read(path)


def run_script(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=600,
                          cwd=cwd)


@pytest.fixture(scope="module")
def chess_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("pictures")
    run = run_script("--scenes", "chess", "--out", str(out), "--width", str(WIDTH), "--height", str(HEIGHT),
                     "--detail", str(DETAIL), "--cycles-samples", "1", "--eevee-samples", "1", "--tiles", cwd=out)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return out, run


def test_the_sheet_is_the_six_tiles_in_two_rows_under_a_title(chess_run, pictures):
    out, _ = chess_run
    sheet = read_png(out / "chess.png")
    gap = pictures.GAP_PX
    assert sheet.shape[1] == 3 * WIDTH + 4 * gap and sheet.shape[2] == 3
    title = sheet.shape[0] - 2 * (HEIGHT + gap)
    assert 0 < title < HEIGHT
    label_rows = title  # the label band of a tile is no taller than the title bar
    for r, row in enumerate(pictures.TILE_ORDER):
        for c, key in enumerate(row):
            tile = read_png(out / f"chess_{key}.png")
            assert tile.shape == (HEIGHT, WIDTH, 3), key
            y, x = title + r * (HEIGHT + gap), gap + c * (WIDTH + gap)
            region = sheet[y:y + HEIGHT, x:x + WIDTH]
            np.testing.assert_array_equal(region[label_rows:], tile[label_rows:], err_msg=key)
            assert not np.array_equal(region[:label_rows], tile[:label_rows]), f"{key} has no label"
    assert set(pictures.TILE_ORDER[0] + pictures.TILE_ORDER[1]) == set(TILE_KEYS)


def test_the_tiles_are_pictures_and_the_json_holds_the_numbers(chess_run):
    out, run = chess_run
    numbers = json.loads((out / "chess.json").read_text())
    assert numbers["scene"] == "chess" and numbers["frame"] == 0 and numbers["resolution"] == [WIDTH, HEIGHT]
    assert numbers["detail"] == DETAIL
    assert 0 < numbers["triangles_bvh"] < numbers["triangles_total"]
    assert math.isfinite(numbers["flip_mean"]) and 0.0 <= numbers["flip_mean"] <= 1.0
    assert numbers["flip_mean"] <= SAME_SCENE_FLIP_MAX
    for mode in ("HYBRID", "FULL_BVH", "PROVENANCE"):
        frame = numbers["hybrid_rt"][mode]
        assert frame["total_ms"] > 0 and "trace" in frame["passes_ms"], mode
    assert numbers["cycles"]["samples"] == 1 and numbers["cycles"]["seconds"] > 0
    # The look against Cycles: HYBRID always, EEVEE when it could render.
    assert 0.0 < numbers["flip_vs_cycles"]["HYBRID"] < 1.0
    assert ("EEVEE" in numbers["flip_vs_cycles"]) == numbers["eevee"]["available"]
    printed = re.search(r"chess FLIP mean ([0-9.]+)", run.stdout)
    assert printed and abs(float(printed.group(1)) - numbers["flip_mean"]) <= 1e-4  # the JSON keeps 5 decimals

    tiles = {key: read_png(out / f"chess_{key}.png") for key in TILE_KEYS}
    shown = [key for key in TILE_KEYS if key != "eevee" or numbers["eevee"]["available"]]
    for key in shown:
        assert np.ptp(tiles[key]) >= MIN_TILE_SPREAD, f"{key} is one flat colour"
    if not numbers["eevee"]["available"]:  # the documented fallback: a labelled grey tile
        assert numbers["eevee"]["reason"] and "EEVEE unavailable" in run.stdout
    # PROVENANCE paints specular pixels pure blue (BVH) or red (cube map): both appear.
    rgb = tiles["provenance"].astype(int)
    assert ((rgb[..., 2] > 150) & (rgb[..., 0] < 100)).any()
    assert ((rgb[..., 0] > 150) & (rgb[..., 2] < 100)).any()


def test_cycles_shows_the_frame_the_right_way_up(chess_run):
    """Cycles' tile matches the FULL_BVH tile's rows better than their mirror image: both
    renderers' results reach the sheet with the top row first."""
    out, _ = chess_run

    def rows(key):
        return read_png(out / f"chess_{key}.png").astype(float).mean(axis=(1, 2))

    cycles, reference = rows("cycles"), rows("full_bvh")
    assert np.corrcoef(cycles, reference)[0, 1] > np.corrcoef(cycles[::-1], reference)[0, 1]


def test_a_scene_without_its_files_stops_the_run_before_any_render(tmp_path):
    assets, out = tmp_path / "empty_assets", tmp_path / "out"
    assets.mkdir()
    run = run_script("--scenes", "chess,sponza", "--assets", str(assets), "--out", str(out),
                     "--width", "32", "--height", "18", "--detail", "0.02", cwd=tmp_path)
    assert run.returncode == 2, run.stdout[-2000:] + run.stderr[-2000:]
    assert "Sponza_blender.gltf" in run.stderr and str(assets / "sponza") in run.stderr
    assert not (out / "chess.png").exists()  # chess, listed first, was not rendered either


def test_skip_missing_leaves_out_only_the_scenes_without_files(tmp_path, pictures):
    scenes, skipped = pictures.check_scene_assets(["chess", "chess_real", "sponza"], tmp_path, skip_missing=True)
    assert scenes == ["chess"]
    assert len(skipped) == 2 and "chess_set_2k.gltf" in skipped[0] and "Sponza_blender.gltf" in skipped[1]


def test_flip_map_gives_the_benchmarks_mean_with_the_error_where_the_images_differ(rng, pictures):
    load_addon()
    from benchmarks import bench

    reference = rng.uniform(0.0, 1.0, (40, 64, 4)).astype(np.float32)
    test = reference.copy()
    test[-10:, :, :3] = 1.0 - test[-10:, :, :3]  # the top rows (row 0 is the bottom, as Blender)
    colours, mean = pictures.flip_map(reference, test)
    assert mean == pytest.approx(bench.flip_mean(reference, test), abs=1e-6)
    assert colours.shape == (40, 64, 3) and colours.dtype == np.uint8
    # The magma map is dark for no error: the differing rows are the map's first (top) rows.
    assert colours[:10].mean() > colours[10:].mean() + 50


def test_sheets_are_written_losslessly_at_the_highest_compression(pictures, tmp_path):
    """The sheets are kept in git: written by OpenImageIO at zlib level 9, smaller than at
    its default level, and read back exactly."""
    load_addon()
    from hybrid_rt.blender_adapter import chart_images

    y, x = np.mgrid[0:120, 0:180]
    smooth = np.stack([x * 2 + y, y * 3, (x + y) // 2], axis=-1).astype(np.uint8)
    size = pictures.write_png(tmp_path / "sheet.png", smooth)
    np.testing.assert_array_equal(read_png(tmp_path / "sheet.png"), smooth)
    assert size == (tmp_path / "sheet.png").stat().st_size
    chart_images.write_png(tmp_path / "default.png", smooth)
    assert size < (tmp_path / "default.png").stat().st_size


def test_a_label_is_white_text_on_a_black_band_that_leaves_the_rest_of_the_tile(pictures):
    """blf draws the label inside its band; the tile's pixels below the band are untouched."""
    load_addon()
    tile = np.full((54, 96, 3), 128, np.uint8)
    out = pictures.labelled(tile, "HYBRID 12 ms")
    band, _pad = pictures.label_band(pictures.label_size(96))
    np.testing.assert_array_equal(out[band:], tile[band:])
    assert (out[:band] == 0).all(axis=-1).sum() > 50  # the black band
    assert (out[:band] > 200).all(axis=-1).sum() > 10  # the white text on it


def test_detail_takes_one_number_or_scene_pairs(pictures):
    scenes = ["chess", "large"]
    assert pictures.parse_details(None, scenes) == {k: pictures.DEFAULT_DETAIL[k] for k in scenes}
    assert pictures.parse_details("0.3", scenes) == {"chess": 0.3, "large": 0.3}
    assert pictures.parse_details("large=0.1", scenes) == {"chess": pictures.DEFAULT_DETAIL["chess"], "large": 0.1}
    with pytest.raises(ValueError, match="scene=value"):
        pictures.parse_details("hall=0.5", scenes)
