"""Where the repository, its golden files and the firmware-sim binary are."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

PYTHON_DIR = Path(__file__).resolve().parent.parent
REPO = PYTHON_DIR.parent
DATA = REPO / "firmware-sim" / "tests" / "data"


def find_firmware_sim() -> Path | None:
    """``$FIRMWARE_SIM``, else ``$CARGO_TARGET_DIR/debug/firmware-sim``, else the repository's
    ``target/debug/firmware-sim``."""
    candidates = []
    if os.environ.get("FIRMWARE_SIM"):
        candidates.append(Path(os.environ["FIRMWARE_SIM"]))
    if os.environ.get("CARGO_TARGET_DIR"):
        candidates.append(Path(os.environ["CARGO_TARGET_DIR"]) / "debug" / "firmware-sim")
    candidates.append(REPO / "target" / "debug" / "firmware-sim")
    return next((c for c in candidates if c.is_file() and os.access(c, os.X_OK)), None)


def load_golden(name: str) -> Any:
    """A golden file of firmware-sim's tests, parsed."""
    return json.loads((DATA / name).read_text(encoding="utf-8"))
