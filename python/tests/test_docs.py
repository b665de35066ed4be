"""docs/python.md's worked example, run exactly as written from the repository root (its run
folders go to a temporary folder)."""
import os
import re

from conftest import SOURCE


def test_python_md_example(monkeypatch, capsys):
    text = (SOURCE / "docs/python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    monkeypatch.chdir(SOURCE)
    before = set(os.listdir(SOURCE))
    exec(compile(blocks[0], "docs/python.md", "exec"), {})
    out = capsys.readouterr().out
    assert "status complete" in out and "determined" in out and "\n2 error: " in out
    assert set(os.listdir(SOURCE)) == before  # nothing written into the work tree
