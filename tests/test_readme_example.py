"""The README's Python example runs as it stands, in a fresh process, from a clone's root
(the shipped problems in problems/): it needs no file that only the CLI would have written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def python_example() -> str:
    text = (ROOT / "README.md").read_text()
    after = text.split("From Python", 1)[1]
    return re.search(r"```python\n(.*?)```", after, re.DOTALL).group(1)


def test_the_readme_python_example_is_self_contained(tmp_path):
    code = python_example()
    assert "coplan.solve(" in code and "load_plan(" in code
    (tmp_path / "problems").symlink_to(ROOT / "problems", target_is_directory=True)  # a clone's root, nothing else
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr[-3000:]
    for path in re.findall(r'load_plan\("([^"]+)"\)', code):
        assert (tmp_path / path).exists()
    assert not (tmp_path / "coplan-out").exists() or "coplan-out" in code


def _anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    text = heading.lstrip("#").strip().lower()
    return "".join(c for c in text if c.isalnum() or c in " -_").replace(" ", "-")


def test_every_link_between_the_readme_and_the_docs_lands_on_a_heading():
    """A regenerated docs page once lost two sections the README still linked to (the widening
    stage's figures, time to quality on long rows): every ``file.md#anchor`` link in the README
    and docs/ must name a heading of that file."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    anchors = {p.resolve(): {_anchor(l) for l in p.read_text().splitlines() if l.startswith("#")} for p in pages}
    broken = []
    for page in pages:
        for target, frag in re.findall(r"\]\(([^)#\s]*\.md)#([^)\s]+)\)", page.read_text()):
            dest = (page.parent / target).resolve()
            if dest in anchors and frag not in anchors[dest]:
                broken.append(f"{page.name} -> {target}#{frag}")
    assert not broken, broken
