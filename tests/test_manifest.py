"""manifest.json: damage in any form is one line naming the command that rebuilds it, that
command rebuilds it byte for byte, and a failed write (a full disk) leaves the old one whole."""

from __future__ import annotations

import errno
import shutil

import pytest

from refspatial.cli import main
from refspatial.manifest import ManifestError, read_manifest

from conftest import TINY
from test_executors import same_files

DAMAGE = {"truncated": lambda text: text[:100], "empty": lambda text: "", "a list": lambda text: "[]",
          "no shards": lambda text: text.replace('"shards"', '"shardz"')}
RERUN = ["generate", "--scenes", "8", "--recipe", str(TINY), "--seed", "7", "--scenes-per-shard", "3",
         "--workers", "1", "--quiet"]


@pytest.fixture(params=sorted(DAMAGE))
def damaged(request, tiny_dataset, tmp_path):
    out = tmp_path / "damaged"
    shutil.copytree(tiny_dataset, out)
    manifest = out / "manifest.json"
    manifest.write_text(DAMAGE[request.param](manifest.read_text()))
    return out


@pytest.mark.parametrize("command", [["stats"], ["verify"], ["show", "--record", "0", "--out", "r.png"]])
def test_readers_of_a_damaged_manifest_say_in_one_line_how_to_rebuild_it(damaged, command, capsys):
    args = [command[0], str(damaged), *command[1:]]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "manifest.json is damaged" in err, err
    # The sidecars give everything but the path of a recipe that is not shipped.
    assert f"refspatial generate --scenes 8 --recipe tiny --seed 7 --scenes-per-shard 3 --out {damaged}" in err
    assert "the path of recipe 'tiny'" in err


def test_the_command_the_message_names_rebuilds_the_manifest_byte_for_byte(damaged, tiny_dataset, capsys):
    with pytest.raises(ManifestError):
        read_manifest(damaged)
    assert main([*RERUN, "--out", str(damaged)]) == 0
    assert "was damaged" in capsys.readouterr().err
    same_files(damaged, tiny_dataset)


def test_an_unfinished_run_is_told_to_finish(tiny_dataset, tmp_path):
    out = tmp_path / "unfinished"
    shutil.copytree(tiny_dataset, out)
    (out / "manifest.json").unlink()
    with pytest.raises(ManifestError, match="did not finish; run `refspatial generate --scenes 8"):
        read_manifest(out)


def test_a_full_disk_while_the_manifest_is_written_keeps_the_old_one(tiny_dataset, tmp_path, monkeypatch, capsys):
    out = tmp_path / "full"
    shutil.copytree(tiny_dataset, out)
    (out / "manifest.json").write_text("[]")  # so that the run has a manifest to write

    def no_space(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("refspatial.atomic.os.fsync", no_space)
    assert main([*RERUN, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "manifest.json could not be written (No space left on device)" in err, err
    assert err.endswith("free space or fix the folder's permissions, then run the same command again to finish")
    assert (out / "manifest.json").read_text() == "[]"
    assert not list(out.rglob("*.partial"))
    monkeypatch.undo()
    assert main([*RERUN, "--out", str(out)]) == 0
    same_files(out, tiny_dataset)


def test_the_loader_and_exports_say_the_same_about_a_damaged_manifest(damaged, tmp_path, capsys):
    from refspatial.data import RefSpatialDataset

    with pytest.raises(ValueError, match="manifest.json is damaged .* it rebuilds manifest.json"):
        RefSpatialDataset(damaged)
    assert main(["export", "parquet", str(damaged), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "manifest.json is damaged" in err, err
