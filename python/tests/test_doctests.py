"""The examples in the package's docstrings run and hold."""

from __future__ import annotations

import doctest

from margin_safe_rl import plant_link


def test_plant_link_examples() -> None:
    result = doctest.testmod(plant_link)
    assert result.attempted > 0 and result.failed == 0
