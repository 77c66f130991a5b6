"""Files written whole: a reader (or a grid started again after a kill) sees the old file or
the new one, never half of one."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Union


def write_whole(path: Path, data: Union[str, bytes]) -> None:
    """Writes ``data`` to a file of its own beside ``path``, flushes it to the disk, then
    renames it over ``path``."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
