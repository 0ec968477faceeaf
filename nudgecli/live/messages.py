"""The schema of the messages a study page may send, checked before the session sees them.

Every websocket message is one JSON object with a ``type`` and exactly that type's fields:

=================  =====================================================================
``type``           fields
=================  =====================================================================
``key``            ``key``: one of ``"1"`` ``"2"`` ``"3"`` ``"4"`` ``" "``; ``down``: a JSON boolean
``axis``           ``value``: a finite number in [-1, 1], or ``null`` (no gamepad)
``start``          none
``skip``           none
``blur``           none
``ping``           none
``questionnaire``  ``answers``: an object of at most :data:`MAX_ANSWERS` names, each a number or
                   ``null`` (the ranges are the questionnaire's, checked when it is recorded)
=================  =====================================================================

Anything else (another type, a missing or extra field, a string where a boolean or number belongs,
a nested array or object, ``NaN``) is refused with a reason: the server replies with an error and
the session does not change. ``disconnect`` is the server's own event and is never accepted from a
page.
"""

from __future__ import annotations

import math
from typing import Any

from nudgecli.live.input import KEY_LABELS

#: Keys a page may report: the four input keys and Space (start).
KEYS = (*KEY_LABELS, " ")
#: Fields of each message type the page may send.
FIELDS: dict[str, tuple[str, ...]] = {
    "key": ("key", "down"),
    "axis": ("value",),
    "start": (),
    "skip": (),
    "blur": (),
    "ping": (),
    "questionnaire": ("answers",),
}
#: Input messages: what only the controlling page may send (a watching page may ``ping``).
INPUT_TYPES = frozenset(FIELDS) - {"ping"}
#: The most answers a questionnaire message may carry (the form has ten).
MAX_ANSWERS = 64
#: The longest text message the server reads (a questionnaire is well under 2 kB).
MAX_MESSAGE_BYTES = 16 * 1024


def _is_number(value: Any) -> bool:
    """A finite JSON number (true/false arrive as bool, a subclass of int: not numbers here)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return True  # any size: Python's ints are exact (math.isfinite would overflow on a huge one)
    return isinstance(value, float) and math.isfinite(value)


def check_message(data: Any) -> str | None:
    """Why ``data`` (a parsed JSON value) is not a valid page message, or ``None`` when it is."""
    if not isinstance(data, dict):
        return "a message is a JSON object with a 'type'"
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in FIELDS:
        return f"unknown message type {kind!r}; expected one of {', '.join(FIELDS)}"
    expected = FIELDS[kind]
    extra = sorted(str(name) for name in data if name != "type" and name not in expected)
    missing = [name for name in expected if name not in data]
    if extra or missing:
        parts = ([f"unknown field(s) {', '.join(extra)}"] if extra else []) + (
            [f"missing field(s) {', '.join(missing)}"] if missing else []
        )
        return f"{kind!r} message: {'; '.join(parts)}"
    if kind == "key":
        if not isinstance(data["key"], str) or data["key"] not in KEYS:
            return f"'key' message: key must be one of {', '.join(repr(k) for k in KEYS)}"
        if not isinstance(data["down"], bool):
            return "'key' message: down must be true or false (a JSON boolean)"
    elif kind == "axis":
        value = data["value"]
        if value is not None and not (_is_number(value) and -1 <= value <= 1):
            return "'axis' message: value must be a number from -1 to 1, or null"
    elif kind == "questionnaire":
        answers = data["answers"]
        if not isinstance(answers, dict) or len(answers) > MAX_ANSWERS:
            return f"'questionnaire' message: answers must be an object of at most {MAX_ANSWERS} answers"
        for name, value in answers.items():
            if value is not None and not _is_number(value):
                return f"'questionnaire' message: answer {str(name)[:40]!r} must be a number or null"
    return None
