"""The command line as a user meets it: help, errors with exit status 2, MJCF export, stats."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from refspatial.cli import main

from conftest import TINY


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "refspatial.cli", *args], capture_output=True, text=True, timeout=300)


def test_help_lists_subcommands():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("generate", "stats", "scene"):
        assert cmd in r.stdout


def _arguments(parser, path=("refspatial",)):
    """(command path, action) for every argument of every parser, subcommands included."""
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:  # the subcommand's line in its parent's help
                yield path + (choice.dest,), choice
            for name, sub in action.choices.items():
                yield from _arguments(sub, path + (name,))
        elif not isinstance(action, argparse._HelpAction):
            yield path, action


def test_every_argument_has_help_and_states_its_default():
    from refspatial.cli import build_parser

    missing, no_default = [], []
    for path, action in _arguments(build_parser()):
        name = " ".join(path) + " " + ("/".join(action.option_strings) or action.dest)
        if not (action.help or "").strip():
            missing.append(name)
        default = action.default
        quiet_default = default is None or default is False or default == []
        if action.option_strings and not action.required and not quiet_default and "default" not in (action.help or ""):
            no_default.append(f"{name} (default {default!r})")
    assert not missing, f"arguments without help: {missing}"
    assert not no_default, f"help that hides the default: {no_default}"


def test_recipes_lists_each_with_its_own_description(tmp_path, monkeypatch, capsys):
    import yaml

    import refspatial.recipe as recipe_module
    from refspatial.paths import recipes_dir

    shipped = recipes_dir()
    assert main(["recipes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = sorted(p.stem for p in shipped.glob("*.yaml"))
    assert [line.split()[0] for line in lines] == names
    for name, line in zip(names, lines):
        description = yaml.safe_load((shipped / f"{name}.yaml").read_text())["description"]
        assert line.endswith("  " + description)
    # A recipe without a description of its own does not borrow the one it extends.
    (tmp_path / "tabletop.yaml").write_text((shipped / "tabletop.yaml").read_text())
    (tmp_path / "plain.yaml").write_text("extends: tabletop\nname: plain\n")
    monkeypatch.setattr(recipe_module, "recipes_dir", lambda: tmp_path)
    assert main(["recipes"]) == 0
    assert capsys.readouterr().out.splitlines()[0].split() == ["plain", "(no", "description)"]


@pytest.mark.parametrize(
    "args, needle",
    [
        (["generate", "--scenes", "2", "--recipe", "no_such_recipe"], "unknown recipe 'no_such_recipe'"),
        (["generate", "--scenes", "-3"], "expected a number >= 0"),
        (["generate", "--scenes", "1", "--workers", "0"], "expected a number >= 1"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, needle, tmp_path):
    r = run(*args, "--out", str(tmp_path / "out"))
    assert r.returncode == 2
    assert needle in r.stderr
    assert not (tmp_path / "out").exists()


def test_malformed_recipe_yaml(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nobjects: {count: [3, \n")
    assert main(["generate", "--scenes", "1", "--recipe", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "not valid YAML" in err and err.count("\n") == 0
    assert not (tmp_path / "o").exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write anywhere; the read-only case needs a normal user")
def test_unwritable_output_folder(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert main(["generate", "--scenes", "1", "--out", str(locked / "ds")]) == 2
    assert "cannot write" in capsys.readouterr().err


@pytest.mark.parametrize("where, needle", [
    ("file", "--out {file} is a file, not a folder"),
    ("file/ds", ": {file} is a file, not a folder"),
    ("holder", "holds a file named shards where the shards folder goes"),
    ("busy", "another `refspatial generate` is writing to"),
])
def test_a_run_refused_before_it_starts_prints_one_line_and_no_summary(where, needle, tmp_path, capsys):
    """Without --quiet: the progress summary ("stopped: 0 scenes in <uptime>") is for runs that started."""
    import fcntl

    (tmp_path / "file").write_text("precious")
    (tmp_path / "holder").mkdir()
    (tmp_path / "holder" / "shards").write_text("precious")
    (tmp_path / "busy").mkdir()
    fd = os.open(tmp_path / "busy", os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)  # as a running `refspatial generate` holds it
    try:
        assert main(["generate", "--scenes", "1", "--recipe", str(TINY), "--out", str(tmp_path / where)]) == 2
    finally:
        os.close(fd)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle.format(file=tmp_path / "file") in err, err
    assert (tmp_path / "file").read_text() == (tmp_path / "holder" / "shards").read_text() == "precious"


def test_verify_refuses_a_negative_max_failures_and_counts_in_words(tmp_path, capsys):
    out = tmp_path / "ds"
    assert main(["generate", "--scenes", "1", "--recipe", str(TINY), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    with pytest.raises(SystemExit) as refused:
        main(["verify", str(out), "--max-failures", "-1"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and err == ("refspatial verify: error: argument --max-failures: expected a "
                                              "number >= 0, got -1 (see refspatial verify --help)\n")
    assert main(["verify", str(out), "--max-failures", "0"]) == 0
    assert capsys.readouterr().out.startswith("verified 1 shard, 2 records, ")


@pytest.mark.parametrize("argv", [["generate", "--scenes", "x"], ["generate"], [], ["export", "roborefer"],
                                  ["stats", "--no-such-flag", "d"]])
def test_usage_errors_are_one_line_and_exit_2(argv, capsys):
    """argparse prints the whole usage before its error (eight lines for generate); ours is one."""
    with pytest.raises(SystemExit) as refused:
        main(argv)
    err = capsys.readouterr().err
    assert refused.value.code == 2 and err.count("\n") == 1 and ": error: " in err and "--help)" in err


def test_the_strict_audit_of_a_damaged_folder_is_one_line(tmp_path, capsys):
    from refspatial.strict_audit import main as audit_main

    (tmp_path / "manifest.json").write_text("[]")
    assert audit_main([str(tmp_path)]) == 2 and audit_main([str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(line.startswith("strict_audit: error: ") for line in err)


def test_a_rerun_that_made_nothing_says_so(tmp_path, capsys):
    out = tmp_path / "ds"
    args = ["generate", "--scenes", "3", "--scenes-per-shard", "2", "--recipe", str(TINY), "--out", str(out),
            "--workers", "1", "--quiet"]
    assert main(args) == 0
    first = capsys.readouterr().out
    assert first.startswith("wrote ") and "from 3 scenes" in first
    assert main(args) == 0
    assert capsys.readouterr().out.startswith(f"nothing to do: {out} already holds ")
    for path in (out / "shards").glob("shard-00001.*"):
        path.unlink()
    assert main(args) == 0
    assert capsys.readouterr().out.startswith(f"made 1 of 3 scenes; {out} now holds ")


def test_generate_and_stats_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "ds"
    assert main(["generate", "--scenes", "2", "--recipe", str(TINY), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    assert capsys.readouterr().out.startswith("wrote ")
    assert main(["stats", str(out), "--json"]) == 0
    stats = json.loads(capsys.readouterr().out)
    assert stats["scenes"] == 2
    assert sum(stats["steps"].values()) == stats["qa"]
    assert main(["stats", str(out)]) == 0
    text = capsys.readouterr().out
    assert "QA per predicate" in text and "objects per category" in text


def test_stats_warns_of_a_shard_whose_checksum_differs_from_its_sidecar(tiny_dataset, tmp_path, capsys):
    import shutil

    out = tmp_path / "changed"
    shutil.copytree(tiny_dataset, out)
    sidecar = out / "shards" / "shard-00001.json"
    side = json.loads(sidecar.read_text())
    sidecar.write_text(json.dumps({**side, "sha256": "0" * 64}))  # as if the file changed after it
    assert main(["stats", str(out), "--json"]) == 0
    stats = json.loads(capsys.readouterr().out)
    assert len(stats["integrity"]) == 1
    assert "shard-00001.mcap: sha256 " in stats["integrity"][0] and "differs from its sidecar's 000000000000" in \
        stats["integrity"][0]
    assert main(["stats", str(out)]) == 0
    assert "\nwarning: " + stats["integrity"][0] in capsys.readouterr().out


def test_stats_over_several_folders_adds_them_up(tmp_path, capsys):
    """One audit over several datasets (one per scene family): counts add, rejections stay per recipe."""
    a, b = tmp_path / "a", tmp_path / "b"
    for out, seed in ((a, "1"), (b, "2")):
        assert main(["generate", "--scenes", "1", "--recipe", str(TINY), "--out", str(out), "--seed", seed,
                     "--workers", "1", "--quiet"]) == 0
    capsys.readouterr()
    single = []
    for out in (a, b):
        assert main(["stats", str(out), "--json"]) == 0
        single.append(json.loads(capsys.readouterr().out))
    assert main(["stats", str(a), str(b), "--json", "--report", str(tmp_path / "both.html")]) == 0
    both = json.loads(capsys.readouterr().out)
    for key in ("scenes", "records", "qa", "shards"):
        assert both[key] == single[0][key] + single[1][key], key
    assert sum(both["categories"].values()) == sum(sum(s["categories"].values()) for s in single)
    assert both["rejected_by_recipe"]["tiny"]["scenes"] == 2
    assert "tiny + tiny" in (tmp_path / "both.html").read_text()


def test_stats_of_a_folder_without_manifest(tmp_path, capsys):
    assert main(["stats", str(tmp_path)]) == 2
    assert "manifest.json not found" in capsys.readouterr().err


def test_scene_writes_mjcf_that_mujoco_loads(tmp_path):
    import mujoco

    for seed in range(10):
        xml = tmp_path / f"scene{seed}.xml"
        if main(["scene", "--recipe", str(TINY), "--seed", str(seed), "--mjcf", str(xml)]) == 0:
            break
    else:
        raise AssertionError("no seed in 10 gave a stable scene")
    model = mujoco.MjModel.from_xml_path(str(xml))
    assert model.nbody >= 4 and model.nmesh >= 3
    assert any(p.suffix == ".stl" for p in Path(tmp_path, f"{xml.stem}_meshes").iterdir())
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    before = data.qpos.copy()
    for _ in range(100):  # it was written at rest, so it stays at rest
        mujoco.mj_step(model, data)
    assert abs(data.qpos - before).max() < 0.005
