"""The numbers the README's studies table states in bold, and the headline numbers of the quick report's
summary.json they must equal."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def studies_table(text: str) -> dict[str, list[str]]:
    """Study name → the bold numbers of its row in the README's studies table (as written)."""
    rows = {}
    for line in text.splitlines():
        m = re.match(r"\|\s*`([\w-]+)`\s*\|", line)
        if m:
            rows[m.group(1)] = re.findall(r"\*\*([-+]?\d[\d ]*(?:\.\d+)?)\*\*", line)
    return rows


def matches(shown: str, values) -> bool:
    """Whether ``shown`` is one of ``values`` rounded to the decimals it is written with."""
    s = shown.replace(" ", "")
    decimals = len(s.split(".")[1]) if "." in s else 0
    return any(v is not None and abs(float(v) - float(s)) <= 0.5 * 10**-decimals + 1e-12 for v in values)


def headline_values(study: dict) -> list[float]:
    """The headline numbers of one study of summary.json (numbers, as the studies read them from their summary)."""
    values = [h[k] for h in study["headline"] for k in ("paper", "rebuild", "best") if h[k] is not None]
    assert all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values), values
    return values
