"""The README's API tour runs: every ```python block, in order, in one namespace."""

from __future__ import annotations

import re

from tests.conftest import REPO_ROOT


def test_readme_python_blocks_run(tmp_path, monkeypatch) -> None:
    text = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 4, "the README's API tour lost its code blocks"
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {}
    for i, block in enumerate(blocks):
        code = block.replace("/tmp/arm_identifier.npz", str(tmp_path / "arm.npz"))
        exec(compile(code, f"README.md block {i + 1}", "exec"), namespace)  # noqa: S102
    assert namespace["report"].data["mismatch"]["significant"] is True
    assert any(e["effect"] == "coulomb_friction" for e in namespace["report"].data["effects"])
