"""`refspatial show`: layout, markers where the answers are, index errors, determinism."""

import argparse
import errno
from pathlib import Path

import cv2
import numpy as np
import pytest

from refspatial.assets import load_catalogue
from refspatial.recipe import load_recipe
from refspatial.shards import generate
from refspatial.show import add_cli, choose_qa, read_record, render_record
from refspatial.show_layout import GAP_PX, PANEL_WIDTH_PX, QA_COLORS, ShowError
from refspatial.show_overlay import free_region_mask

from conftest import TINY


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("show-dataset")
    manifest = generate(out, load_recipe(str(TINY)), load_catalogue(), n_scenes=3, base_seed=11, workers=1,
                        scenes_per_shard=2)
    assert manifest["records"] >= 2 and len(manifest["shards"]) == 2
    return out


@pytest.fixture(scope="module")
def records(dataset):
    """JSON parts of every record, in the loader's (manifest) order."""
    from refspatial.data import RefSpatialDataset

    return list(RefSpatialDataset(dataset, fields=()))


@pytest.fixture(scope="module")
def sample(dataset, records):
    """The last record with a point question, read through the global index."""
    g = max(g for g, s in enumerate(records) if any(q["answer_points"] for q in s["qa"]))
    return read_record(dataset, g)


def _rgb(path) -> np.ndarray:
    return cv2.cvtColor(cv2.imread(str(path), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


def _hex(color: str) -> np.ndarray:
    return np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])


def _point_qa(sample) -> int:
    return next(j for j, qa in enumerate(sample["qa"]) if qa["answer_points"])


def test_global_index_follows_manifest_order(dataset, records):
    keys = [s["key"] for s in records]
    last = read_record(dataset, len(keys) - 1)
    assert last["key"] == keys[-1] and last["shard"] == "shard-00001.mcap"
    assert read_record(dataset, 0)["key"] == keys[0] and "rgb" in last and "seg" in last


def test_png_has_the_planned_size_and_markers_on_the_answers(sample, tmp_path):
    j = _point_qa(sample)
    out = tmp_path / "one.png"
    layout = render_record(sample, [j], out)
    img = _rgb(out)
    assert img.shape[:2] == (layout.size[1], layout.size[0])
    assert layout.size[0] == PANEL_WIDTH_PX + GAP_PX + PANEL_WIDTH_PX // 2
    h, w = sample["seg"].shape
    assert layout.main[3] == round(PANEL_WIDTH_PX * h / w) and img.shape[0] > layout.main[1] + layout.main[3]
    bare = _rgb(_written(render_record, sample, [], tmp_path / "bare.png"))
    for x, y in sample["qa"][j]["answer_points"]:
        col, row = layout.to_pixel(x, y)
        assert np.abs(img[row, col].astype(int) - _hex(QA_COLORS[0])).max() <= 2, (x, y)
        assert np.abs(bare[row, col].astype(int) - _hex(QA_COLORS[0])).max() > 30, "colour came from the marker"


def test_zoom_keeps_the_width_and_puts_markers_where_the_layout_says(sample, tmp_path):
    j = _point_qa(sample)
    layout = render_record(sample, [j], tmp_path / "zoom.png", zoom=True)
    img = _rgb(tmp_path / "zoom.png")
    h, w = sample["seg"].shape
    x0, y0, cw, ch = layout.crop
    assert cw < w and abs(cw / ch - w / h) < 1e-6 and 0 <= x0 <= w - cw and 0 <= y0 <= h - ch
    assert img.shape[:2] == (layout.size[1], layout.size[0]) and img.shape[1] == PANEL_WIDTH_PX * 3 // 2 + GAP_PX
    for x, y in sample["qa"][j]["answer_points"]:
        col, row = layout.to_pixel(x, y)
        assert np.abs(img[row, col].astype(int) - _hex(QA_COLORS[0])).max() <= 2


def _written(fn, sample, qa, path):
    fn(sample, qa, path)
    return path


def test_same_record_same_bytes(sample, tmp_path):
    qa = choose_qa(sample, None)
    a = _written(render_record, sample, qa, tmp_path / "a.png")
    b = _written(render_record, sample, qa, tmp_path / "b.png")
    assert a.read_bytes() == b.read_bytes()
    assert b"Software" not in a.read_bytes()


def test_out_of_range_record_names_the_valid_range(dataset, records):
    n = len(records)
    for bad in (n, -1):
        with pytest.raises(ShowError, match=rf"--record {bad} is out of range.*records 0\.\.{n - 1}"):
            read_record(dataset, bad)


def test_qa_choice_and_its_errors(sample):
    n = len(sample["qa"])
    assert choose_qa(sample, None) == list(range(min(n, 4)))
    assert choose_qa(sample, [1, 0, 1]) == [1, 0]
    with pytest.raises(ShowError, match=rf"--qa {n}: .* has QA 0\.\.{n - 1}"):
        choose_qa(sample, [0, n])


def test_command_writes_the_png(dataset, tmp_path, capsys):
    parser = argparse.ArgumentParser()
    add_cli(parser.add_subparsers(dest="command"))
    out = tmp_path / "cmd.png"
    args = parser.parse_args(["show", str(dataset), "--record", "0", "--out", str(out), "--qa", "0"])
    assert args.func(args) == 0
    assert out.is_file() and "record 0" in capsys.readouterr().out
    bad = parser.parse_args(["show", str(dataset), "--record", "0", "--out", str(tmp_path / "x.jpg")])
    with pytest.raises(ShowError, match=r"\.png"):
        bad.func(bad)


@pytest.mark.parametrize("where, needle", [("file/r.png", "file is a file, not a folder"),
                                           ("folder.png", "cannot write it (Is a directory)")])
def test_an_out_that_cannot_be_written_is_one_line_and_exit_2(dataset, tmp_path, capsys, where, needle):
    from refspatial.cli import main

    (tmp_path / "file").write_text("precious")
    (tmp_path / "folder.png").mkdir()
    assert main(["show", str(dataset), "--record", "0", "--out", str(tmp_path / where)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err
    assert (tmp_path / "file").read_text() == "precious"


def test_a_full_disk_leaves_the_old_png_whole_and_no_partial_file(sample, tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    out = tmp_path / "r.png"
    out.write_bytes(b"the old picture")

    def half_then_full(self, path, **kw):
        Path(path).write_bytes(b"\x89PNG half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", half_then_full)
    with pytest.raises(ShowError, match=r"cannot write it \(No space left on device\); choose another path"):
        render_record(sample, [0], out)
    assert out.read_bytes() == b"the old picture" and sorted(tmp_path.iterdir()) == [out]


def test_free_mask_decodes_and_must_fit_the_image():
    from refspatial.annotate import rle_encode

    mask = np.zeros((6, 8), bool)
    mask[2:5, 3:7] = True
    assert (free_region_mask({"free_mask": rle_encode(mask)}, (6, 8)) == mask).all()
    assert free_region_mask({}, (6, 8)) is None
    with pytest.raises(ShowError, match="free_mask is 6x8 but the image is 8x6"):
        free_region_mask({"free_mask": rle_encode(mask)}, (8, 6))
    with pytest.raises(ShowError, match="not a valid run-length code"):
        free_region_mask({"free_mask": {"size": [6, 8], "counts": [3, 4]}}, (6, 8))


def test_a_free_region_and_marks_are_drawn(sample, tmp_path):
    from refspatial.annotate import rle_encode

    j = _point_qa(sample)
    h, w = sample["seg"].shape
    plain = _rgb(_written(render_record, sample, [j], tmp_path / "plain.png"))
    free = np.zeros((h, w), bool)
    free[h // 20: h // 4, w // 20: w // 4] = True  # top-left, away from the objects
    box = [w // 2, h * 3 // 4, w * 3 // 4, h - 2]
    qa = {**sample["qa"][j], "free_mask": rle_encode(free), "marks": [{"box_px": box, "rgb": [0, 0, 255]}]}
    layout = render_record({**sample, "qa": [qa]}, [0], tmp_path / "drawn.png")
    drawn = _rgb(tmp_path / "drawn.png")
    assert plain.shape == drawn.shape
    (c0, r0), (c1, r1) = layout.to_pixel(0.06, 0.06), layout.to_pixel(0.24, 0.24)
    assert (plain[r0:r1, c0:c1] != drawn[r0:r1, c0:c1]).mean() > 0.2
    col, row = layout.to_pixel((box[0] + 0.5) / w, (box[1] + box[3]) / 2 / h)
    blue = np.array([0, 0, 255])
    assert np.abs(drawn[row, col].astype(int) - blue).max() < 40 < np.abs(plain[row, col].astype(int) - blue).max()


def test_steps_of_the_other_view_are_not_drawn_here():
    """A multi-view trace: Position steps follow the program's unique nodes, whose view says which image."""
    from refspatial.show_overlay import step_views

    qa = {"steps": [{"op": "unique", "view": "other", "result": 3}, {"op": "relate"},
                    {"op": "unique", "view": "other", "result": 1}, {"op": "unique", "result": 1}],
          "reasoning_steps": [{"kind": "Position", "point": [0.1, 0.1]}, {"kind": "Size", "value": 0.1},
                              {"kind": "Position", "point": [0.2, 0.2]}, {"kind": "Position", "point": [0.3, 0.3]},
                              {"kind": "Position", "point": [0.4, 0.4]}]}
    assert [v for _, v in step_views(qa)] == ["other", "self", "other", "self", "self"]
