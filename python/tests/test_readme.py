"""The README's Python example runs and prints what the README says it prints."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from paths import PYTHON_DIR


def test_readme_example_prints_its_quoted_output(
    firmware_sim: str, python_env: dict[str, str]
) -> None:
    text = (PYTHON_DIR / "README.md").read_text(encoding="utf-8")
    (code,) = re.findall(r"```python\n(.*?)```", text, re.S)
    printed = re.search(r"```text\n(.*?)```", text[text.index(code) :], re.S)
    assert printed is not None
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**python_env, "FIRMWARE_SIM": firmware_sim},
        timeout=60,
        cwd=os.fspath(PYTHON_DIR),
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == printed.group(1)
