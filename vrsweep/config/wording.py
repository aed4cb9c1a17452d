"""Small text helpers shared by the config's messages: how a value, a path or a near miss is shown."""

import difflib
import os

from vrsweep.errors import clip


def did_you_mean(word, choices) -> str:
    """`` (did you mean 'Delta'?)`` for a near miss, case-insensitively first; else ''."""
    word = str(word)
    by_case = [choice for choice in choices if choice.lower() == word.lower()]
    close = by_case or difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def dotted(path) -> str:
    """('sweep', 'g', 'values', 3) -> 'sweep.g.values[3]'."""
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


def show(value) -> str:
    """A value as the user wrote it, kept short."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif value is None:
        text = "null"
    else:
        text = repr(value)
    return clip(text)


def show_number(value) -> str:
    """0.0 -> '0', 1.0 -> '1', 1e-9 -> '1e-09' (for intervals in messages)."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def and_list(items) -> str:
    """[2, 5, 7] -> '2, 5 and 7'."""
    items = [str(item) for item in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def folder_ending(path) -> str | None:
    """How ``path``, as typed, ends when it names a folder, worded for a message: "a slash" for a
    ``/`` (or the system's other separator), "'/.'" for a ``/.``; None for a file's name (and for a
    pathlib.Path, which has already dropped both). pathlib drops either ending, so ``-o x.h5/.``
    wrote a file ``x.h5``: every path arriving as text is asked this before it becomes a Path."""
    if not isinstance(path, str):
        return None
    separators = tuple(sep for sep in (os.sep, os.altsep) if sep)
    if path.endswith(separators):
        return "a slash"
    if any(path.endswith(sep + ".") for sep in separators):
        return "'/.'"
    return None
