"""IPOPT settings checked before any work: :func:`ipopt_option_issues`.

``OptimalOptions.ipopt`` is passed through to CasADi's ``nlpsol`` (``ipopt.<IPOPT option>``,
or one of CasADi's own nlpsol options). A name IPOPT does not know, a value of the wrong type or
outside the option's range used to pass the options check and fail minutes later, deep inside
the first program, as an internal error. Each setting is tried here on a one-variable program
(built, not solved: CasADi and IPOPT check the options when the solver is built), and what they
say becomes an issue naming the setting.
"""

from __future__ import annotations

import contextlib
import difflib
import io
import os
import re
import sys
import tempfile

__all__ = ["ipopt_option_issues"]

_QUIET = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes"}


def _captured(fn):
    """``fn()`` with the process's stdout (file descriptor 1, where IPOPT prints what it finds
    wrong) captured: ``(result or the RuntimeError, the text printed)``."""
    sys.stdout.flush()
    text = io.StringIO()  # (CasADi prints through Python's sys.stdout where it can: both are caught)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = os.dup(1)
        try:
            os.dup2(tmp.fileno(), 1)
            try:
                with contextlib.redirect_stdout(text):
                    out = fn()
            except RuntimeError as e:
                out = e
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        tmp.seek(0)
        return out, text.getvalue() + tmp.read().decode("utf-8", errors="replace")


def _reason(key: str, value, err: RuntimeError, printed: str) -> str:
    """The message for one refused setting, from CasADi's error and IPOPT's printout."""
    text = str(err)
    found = f"found {value!r}"
    m = re.search(r"Unknown option: (\S+)", text)
    if m:
        near = re.search(r'Did you mean one of the following\?\s*\n>\s*"([^"]+)"', text)
        # (CasADi lists its nearest names by edit distance: only a close one is a hint)
        close = near and difflib.SequenceMatcher(None, key, near.group(1)).ratio() >= 0.75
        hint = f"; did you mean {near.group(1)!r}?" if close else ""
        return (f"expected one of CasADi's nlpsol options or 'ipopt.<IPOPT option>', found unknown key {key!r}{hint}")
    m = re.search(r"No such IPOPT option: (\S+)", text)
    if m:
        return f"expected an IPOPT option name after 'ipopt.', found {m.group(1)!r} (see IPOPT's options reference)"
    if "type mismatch" in text or "Assertion" in text:
        return f"expected a value of the type IPOPT's {key.removeprefix('ipopt.')} takes, {found}"
    setting = re.search(r'Setting: "([^"]*)" is not a valid setting for Option: (\S+)\.', printed)
    if setting:
        lines = [ln.strip() for ln in printed.splitlines()]
        rng = next((ln for ln in lines if "<=" in ln), None)
        valid = [ln.split(" (", 1)[0] for ln in lines if ln and not ln.startswith(("Setting", "#", "Category", "Description",
                                                                                      "Valid", "Default")) and "<=" not in ln]
        want = (f" ({rng})" if rng else f" (one of: {', '.join(valid)})" if valid else "")
        return f"expected a valid setting of IPOPT's {setting.group(2).rstrip('.')}{want}, {found}"
    first = next((ln.strip() for ln in text.splitlines() if ln.strip()), "refused")
    return f"expected a setting CasADi's IPOPT interface accepts, {found} ({first.split(': ', 1)[-1][:120]})"


def ipopt_option_issues(settings: dict) -> list[tuple[str, str]]:
    """``[(key, message), ...]`` for the settings of ``settings`` that CasADi or IPOPT refuse
    (empty: all good). Keys must be strings, values numbers, strings or booleans."""
    bad: list[tuple[str, str]] = []
    if not settings:
        return bad
    import casadi as ca

    x = ca.MX.sym("x")
    nlp = {"x": x, "f": (x - 1.0) ** 2}
    for key, value in settings.items():
        if not isinstance(key, str):
            bad.append((str(key), f"expected an option name (a string), found {type(key).__name__} {key!r}"))
            continue
        if isinstance(value, (dict, list, tuple)) or value is None:
            bad.append((key, f"expected a number, a string or a boolean, found {type(value).__name__} {value!r}"))
            continue
        out, printed = _captured(lambda: ca.nlpsol("coplan_probe", "ipopt", nlp, {**_QUIET, key: value}))
        if isinstance(out, RuntimeError):
            bad.append((key, _reason(key, value, out, printed)))
    return bad
