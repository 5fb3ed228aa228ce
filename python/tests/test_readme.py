"""The README's Python example runs as printed, and its comments tell the truth."""

import re
import runpy

from conftest import REPO


def test_the_readme_example_runs_and_learns_the_cheap_setting(tmp_path, monkeypatch, capsys):
    readme = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, re.S)
    assert blocks, "no python block in README.md"
    example = blocks[0]
    assert len(example.strip().splitlines()) <= 17, "the README example should stay short"
    script = tmp_path / "example.py"
    script.write_text(example)
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(script), run_name="__main__")
    printed = capsys.readouterr().out
    assert printed.startswith("{'rate_hz': 2, 'view_m': "), printed
    assert (tmp_path / "campaign.journal").stat().st_size > 0
