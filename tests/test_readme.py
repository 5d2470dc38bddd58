"""The README's claims, checked against the code so the two cannot drift apart."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end >= 0 else len(README)]


def test_training_example_runs_as_written_against_a_generated_folder(tiny_dataset, tmp_path):
    """The snippet verbatim, in a folder whose data/demo is a generated dataset (what `make demo`
    leaves); a few lines appended afterwards report what the last batch held."""
    pytest.importorskip("torch")
    blocks = re.findall(r"```python\n(.*?)```", section("Training with the loader"), re.S)
    assert len(blocks) == 1
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "demo").symlink_to(tiny_dataset, target_is_directory=True)
    report = ("\nprint(epoch, type(images).__name__, images.dtype, images.ndim, images.shape[-1],"
              " depth.dtype, len(qa) == images.shape[0], type(qa[0]).__name__)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-c", blocks[0] + report], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["2", "Tensor", "torch.uint8", "4", "3", "torch.float32", "True", "list"]


def test_install_commands_work_from_a_checkout():
    """refspatial is not on a package index: every `pip install` names the checkout and extras
    that pyproject.toml defines; `make demo` installs the torch and ray extras, as the README says."""
    pyproject = (ROOT / "pyproject.toml").read_text()
    table = pyproject[pyproject.index("[project.optional-dependencies]"):].split("\n\n")[0]
    extras = set(re.findall(r"^(\w+) = \[", table, re.M))
    assert {"torch", "ray"} <= extras
    commands = re.findall(r"pip install ([^`\n#]+)", README)
    assert commands
    for command in commands:
        m = re.fullmatch(r"-e '\.\[(\w+)\]'\s*", command)
        assert m and m.group(1) in extras, f"README: `pip install {command.strip()}` does not install from a checkout"
    make_install = re.search(r'pip install -q -e "\.\[([\w,]+)\]"', (ROOT / "Makefile").read_text()).group(1)
    assert {"torch", "ray"} <= set(make_install.split(","))
    assert "which `make demo` installs" in README


def test_answer_letters_reach_as_far_as_visual_choice_marks():
    from refspatial.questions.visual import LABELS

    assert f"a letter from `(A)` to `({LABELS[-1]})`" in README
    assert f"lettered `(A)` to `({LABELS[-1]})`" in README


def test_stats_all_clear_line_is_quoted_as_printed():
    from refspatial.stats import NO_WARNINGS

    assert f"the last line says so (`{NO_WARNINGS}`)" in README
