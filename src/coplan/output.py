"""One run's files written as a unit (used by :func:`coplan.pipeline.solve`).

A run's files (plan.json/.csv/.npz, baseline.*, verification.json) are written into a fresh
folder beside the target, named uniquely per process (``.<name>.<random>.partial``), and
only when every file is complete is that folder renamed into place. So a crash, ``kill -9``
or a full disk never leaves one run's plan.json beside another's CSV: the target holds a
whole run or is untouched, and a failed write removes its partial folder.

The previous run is kept: a target folder that holds only coplan's files is renamed to
``<name>.previous`` first (replacing an older one, never a file or folder of the user's of
that name: :func:`check_folder` refuses the run before any work). A target that also holds other files is
not moved: the previous run's files in it move to ``<name>.previous`` (so that no file of one
run is left beside another's: a stop-and-go ``run.json`` beside a later solve's plan), the
user's stay, and the new files go in one by one (each rename atomic). So does a run into the
folder coplan runs in (``-o .``), which is never removed or renamed.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from .errors import CoplanError

__all__ = ["MARKER", "RunFolder", "RunKept", "is_run_folder", "previous_of", "writable_folder", "signals_deferred", "usual_mode", "atomic_text", "atomic_texts", "named_as", "OutputError", "check_folder", "folder_path", "keep_reports", "followed"]

MARKER = ".coplan-run"  # written into every run folder
# the files a run writes (solve, live runs), by their exact names -- a user's plan.md or
# baseline.xlsx is theirs, never moved or removed -- and what coplan writes beside a plan by
# default (`coplan export`: plan_<rate>hz.csv and its .events.csv, or that folder of per-arm
# files, the rate as Python's :g writes it, 1e-05 too; `coplan plot`: plan_<kind>.png, of plan.csv
# plan_csv_<kind>.png), which
# would otherwise stay beside the next run's plan, stale
_OURS = re.compile(r"(plan|baseline)\.(json|csv|npz|html|gif|mp4)|verification\.json|run\.json|live\.gif|planned_problem\.yaml"
                   r"|\.coplan-run|(plan|baseline)_[0-9.]+(e[+-][0-9]+)?hz(\.csv|\.events\.csv)?"
                   r"|(plan|baseline)(_csv|_npz)?_(gantt|clearance|joints|workspace|speed)\.(png|svg|pdf)")


def _ours(p: Path) -> bool:
    """Whether ``p`` (in a run folder) is a file of coplan's, or an export's folder of per-arm files."""
    if not _OURS.fullmatch(p.name):
        return False
    return p.is_dir() == (p.name.startswith(("plan_", "baseline_")) and p.name.endswith("hz"))


class RunKept(OSError):
    """A finished run that could not be moved into its folder: kept whole elsewhere, named in the message."""


class OutputError(CoplanError, ValueError):
    """An output folder coplan cannot write into, found before any work."""


def folder_path(out: Path, what: str, expected: str = "a folder") -> Path:
    """``out`` as a folder to make or write into: :class:`OutputError` where a file is there or
    in its path (what was ``expected`` and found); returns the nearest part of it that exists."""
    if out.exists() and not out.is_dir():
        raise OutputError(f"{what} {out}: expected {expected}, found a file")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{what} {out}: expected {expected}, found the file {probe} in its path")
    return probe


def followed(out: Path) -> Path:
    """``out``, or where it points if it is a symbolic link: a run goes there and the link is kept
    (:class:`RunFolder`, and the checks before the work alike). :class:`OutputError` for a link
    that loops (Python's RuntimeError, an internal error after the work)."""
    out = Path(out)
    if not out.is_symlink():
        return out
    try:
        return out.resolve()
    except (RuntimeError, OSError) as exc:
        raise OutputError(f"{out}: expected a folder or a link to one, found a symbolic link that does not resolve ({exc})") from None


def check_folder(out: str | Path, what: str = "out_dir", files_only: bool = False) -> None:
    """Before any work: ``out`` must be a folder coplan can create or write into (a missing
    parent is created later); :class:`OutputError` says what was expected and found, so that
    a solve of minutes is not lost to a typo in where it goes. ``files_only``: a folder a command
    writes files into (a figure, an export), not a run folder: the rules of a run's
    ``.previous`` do not apply (a user's file in ``<run>.previous`` made export and view refuse
    the run folder itself)."""
    if isinstance(out, bool) or not isinstance(out, (str, os.PathLike)):
        raise TypeError(f"{what}: expected the path of a folder (str or Path), found {type(out).__name__} {out!r}"[:300])
    if isinstance(out, str) and not out:  # (out_dir=os.environ.get("RUN_DIR", "") wrote the run where the program ran)
        raise OutputError(f"{what}: expected the path of a folder, found an empty string (an unset variable?); "
                          "'.' is the current folder")
    out = followed(Path(out))
    probe = folder_path(out, what)
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {out}: expected a folder coplan may write to, found that {probe} is not writable")
    # permission bits do not tell all (root passes os.access; /proc and read-only mounts refuse
    # new files anyway): a hidden file made and removed there says it
    refused = _probe(probe)
    if refused is not None:
        raise OutputError(f"{what} {out}: expected a folder coplan may write to, found that {probe} takes no new files "
                          f"({refused.strerror or refused})")
    if files_only:
        return
    prev = previous_of(out)
    if out.is_dir() and not writable_folder(prev.parent):  # (the run is then staged inside it: RunFolder)
        if any(_ours(p) for p in out.iterdir()):  # (a solve of minutes was lost at its end: "Permission denied")
            raise OutputError(f"{what} {out}: it holds a previous run, which a run there keeps as {prev}, but "
                              f"{prev.parent} is not writable; expected a folder with no coplan run in it, or one "
                              "beside which coplan may write: move that run's files, or choose another folder")
    if out.is_dir() and any(_ours(p) for p in out.iterdir()) and not _replaceable(prev):
        held = "a file" if not prev.is_dir() else "a folder holding files coplan did not write (" + ", ".join(
            sorted(p.name for p in prev.iterdir() if not _ours(p))[:3]) + ")"
        raise OutputError(f"{what} {out}: a run there moves the previous one to {prev}, which would replace what is "
                          f"there; expected coplan's previous run or nothing at {prev}, found {held}: move it, or "
                          "choose another folder")


def _probe(path: str | Path) -> OSError | None:
    """Why a file cannot be made in the folder ``path`` (a hidden one made and removed there:
    permission bits do not tell all), or None when it can."""
    try:
        fd, name = tempfile.mkstemp(prefix=".coplan-probe-", dir=path)
    except OSError as exc:
        return exc
    os.close(fd)
    os.unlink(name)
    return None


def writable_folder(path: str | Path) -> bool:
    """Whether coplan can make a file in the folder ``path`` (:func:`_probe`)."""
    return _probe(path) is None


def previous_of(out: Path) -> Path:
    """Where a run into ``out`` keeps the previous run: ``<out>.previous`` beside it (the
    current folder's too)."""
    out = Path(out)
    full = out.absolute()
    return out.with_name(out.name + ".previous") if out.name else full.with_name(full.name + ".previous")


def _replaceable(prev: Path) -> bool:
    """Whether ``prev`` may be replaced by the next previous run: nothing, an empty folder, or a
    folder of coplan's files only (a user's file or folder of that name is theirs)."""
    if not prev.exists() and not prev.is_symlink():
        return True
    return prev.is_dir() and not prev.is_symlink() and all(_ours(p) for p in prev.iterdir())


def usual_mode(folder: bool = False) -> int:
    """The permissions a file (or folder) the user creates gets: 0666 (0777) less the umask.

    ``tempfile.mkstemp``/``mkdtemp`` create 0600/0700 on purpose; a run's files, renamed into
    place from there, should look like any other file the user writes."""
    mask = os.umask(0)
    os.umask(mask)
    return (0o777 if folder else 0o666) & ~mask


@contextmanager
def named_as(target: Path):
    """An OSError raised while the staging file or folder for ``target`` is created names
    ``target`` (the path the user gave), not the hidden staging name it never asked for."""
    try:
        yield
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from exc


def _staged(path: Path, text: str) -> str:
    """``text`` (UTF-8) written to a temporary file unique per writer beside ``path``, with
    :func:`usual_mode`; its name. A failure removes it and names ``path``."""
    with named_as(path):
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
                f.write(text)
            os.chmod(tmp, usual_mode())
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return tmp


def atomic_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all: a temporary file unique per
    writer beside it (:func:`_staged`), then a rename (a failure removes it, and names ``path``)."""
    path = Path(path)
    tmp = _staged(path, text)
    try:
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_texts(items: list[tuple[Path, str]], remove: list[Path] | tuple = (), before=None) -> None:
    """Write several files as one: each text (UTF-8) to a temporary file beside its path first --
    interruptible, and any failure (a full disk, Ctrl-C) removes them all and names the file it
    was writing -- then, with Ctrl-C and SIGTERM held (:func:`signals_deferred`), every one
    renamed into place and each of ``remove`` deleted. A controller's export was one file from a
    new plan beside the others from the old one after a SIGTERM, or a folder of three arms' files
    of four after a full disk. ``before()``: called with the signals held before any file is put in
    place; what it raises leaves every file as it was. A rename that fails (a folder where a file
    goes) names the file; those put in place before it stay, and the error says which."""
    temps: list[tuple[str, Path]] = []
    try:
        for path, text in items:
            temps.append((_staged(Path(path), text), Path(path)))
        with signals_deferred():
            if before is not None:
                before()
            placed: list[Path] = []
            for tmp, path in temps:
                try:
                    os.replace(tmp, path)
                except OSError as exc:
                    done = f"; put in place before it: {', '.join(p.name for p in placed)}" if placed else ""
                    raise OSError(exc.errno, f"{exc.strerror or exc}{done}", str(path)) from exc
                placed.append(path)
            for p in remove:
                Path(p).unlink(missing_ok=True)
    except BaseException:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        raise


def keep_reports(out: Path, names: tuple[str, ...]) -> list[str]:
    """Before a report is first written into ``out``: each of ``names`` already there (an earlier
    report's file) is renamed ``<stem>.previous<suffix>`` beside it, replacing an older one, as a
    run folder keeps its previous run (a second ``coplan compare`` into a folder had replaced the
    first one's report). Only files: a folder of the user's of that name is left alone. Returns
    the report's note of it (none when nothing was there)."""
    kept = []
    for name in names:
        src = Path(out) / name
        if src.is_file():
            dst = src.with_name(f"{src.stem}.previous{src.suffix}")
            if dst.exists() and not dst.is_file():
                continue  # (not ours to replace: the report is then rewritten, as before)
            with named_as(dst):
                os.replace(src, dst)
            kept.append(dst.name)
    return [f"the previous report in {out}: moved to {', '.join(kept)}"] if kept else []


def atomic_file(path: Path, write) -> None:
    """As :func:`atomic_text`, for a writer: ``write(tmp_path)`` fills a temporary file beside
    ``path``, which then replaces it (``np.savez_compressed``, ``np.savetxt``)."""
    path = Path(path)
    with named_as(path):
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial" + path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, usual_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


#: The run folder written whole while a Ctrl-C or SIGTERM held during its writing is answered
#: (:func:`signals_deferred` given the folder; empty otherwise): the ``coplan`` command's messages
#: then say where the run is -- it said "interrupted", a live run "nothing of this run is kept", of
#: a run written whole with the previous one moved aside.
WRITTEN_BEFORE_SIGNAL: list = []


@contextmanager
def signals_deferred(folder: "RunFolder | None" = None):
    """Ctrl-C and SIGTERM held while the block runs, then answered as they would have been
    (their handlers called, or the signal sent again): a run's files, written in a second or
    two, are written whole -- a Ctrl-C landing there threw away the verified plan the solve had
    spent minutes on, and said it was saved. Main thread only (elsewhere nothing changes).
    ``folder``: the :class:`RunFolder` the block writes; written whole when a held signal is
    answered (the block did not raise), it is :data:`WRITTEN_BEFORE_SIGNAL` while the answer runs,
    and the KeyboardInterrupt an answer raises carries it (``written_run``): a note of it goes
    with that interrupt, never with a later one."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    kinds = [signal.SIGINT] + ([signal.SIGTERM] if hasattr(signal, "SIGTERM") else [])
    old = {k: signal.signal(k, lambda signum, frame: got.append(signum)) for k in kinds}
    try:
        yield
    finally:
        for k, h in old.items():
            signal.signal(k, h)
    if got and folder is not None:  # (here the block did not raise: its run is written)
        WRITTEN_BEFORE_SIGNAL.append(folder)
    try:
        for k in dict.fromkeys(got):  # (once each, in order)
            h = old[k]
            if callable(h):
                try:
                    h(k, None)
                except KeyboardInterrupt as e:
                    if folder is not None:
                        e.written_run = folder
                    raise
            elif h == signal.SIG_DFL:
                os.kill(os.getpid(), k)
    finally:
        WRITTEN_BEFORE_SIGNAL.clear()


def is_run_folder(path: Path) -> bool:
    """Whether ``path`` is a folder holding nothing but files a coplan run writes."""
    if not path.is_dir():
        return False
    entries = list(path.iterdir())
    return bool(entries) and all(_ours(p) for p in entries)


@dataclass
class RunFolder:
    """``with RunFolder(out) as stage:`` write into ``stage``; on a clean exit the files move to
    ``out`` (see the module docstring), on an exception they are removed."""

    out: Path
    stage: Path | None = None
    previous: Path | None = None  # where the previous run was kept, if it was moved
    inside: bool = False  # staged inside ``out`` (nothing may be made beside it)

    def __post_init__(self):
        # (the run goes where a symbolic link points, which keeps pointing at it: the run was kept in
        # <link>.unsaved, exit 8, or the user's link renamed <link>.previous)
        self.out = followed(Path(self.out))

    def __enter__(self) -> Path:
        with named_as(self.out):
            self.out.parent.mkdir(parents=True, exist_ok=True)
            # staged beside the folder; inside it where nothing may be made beside it (check_folder
            # then refuses a folder with a previous run in it, which would go to <out>.previous there)
            self.inside = self.out.is_dir() and not writable_folder(previous_of(self.out).parent)
            self.stage = Path(tempfile.mkdtemp(prefix=f".{self.out.name or 'coplan-run'}.", suffix=".partial",
                                               dir=self.out if self.inside else self.out.parent))
        try:
            self.stage.chmod(usual_mode(folder=True))  # mkdtemp's 0700 is for the staging, not the run
            (self.stage / MARKER).write_text("files of one coplan run\n")
        except BaseException:  # (a Ctrl-C right here left the hidden staging folder behind for good)
            shutil.rmtree(self.stage, ignore_errors=True)
            raise
        return self.stage

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            shutil.rmtree(self.stage, ignore_errors=True)
            if isinstance(exc, OSError) and exc.filename is None:  # (a full disk said only "No space left on device")
                raise OSError(exc.errno, exc.strerror or str(exc), str(self.out)) from exc
            return False
        try:
            self._commit()
        except OSError as e:  # (Windows refuses to rename a folder with a file open in it: a finished solve was thrown away)
            kept = self._keep_stage()
            if kept is None:
                shutil.rmtree(self.stage, ignore_errors=True)
                raise
            hint = " (a file there open in another program?)" if isinstance(e, PermissionError) else ""
            raise RunKept(e.errno, f"{e.strerror or e}: the run could not be moved into {self.out}{hint}; it is kept "
                                   f"whole in {kept}", str(self.out)) from e
        except BaseException:
            shutil.rmtree(self.stage, ignore_errors=True)
            raise
        return False

    def _keep_stage(self) -> Path | None:
        """The staged run under a visible name beside its folder, ``<out>.unsaved`` (or ``.unsaved.N``),
        when it cannot be moved into place; None if that fails too."""
        base = self.out.absolute()
        first = base / "unsaved" if self.inside else base.with_name(base.name + ".unsaved")
        target, n = first, 1
        while target.exists():
            target, n = first.with_name(f"{first.name}.{n}"), n + 1
        try:
            self.stage.rename(target)
        except OSError:
            return None
        return target

    def path(self, staged: Path) -> Path:
        """Where a file written into the stage ends up."""
        return self.out / Path(staged).name

    def _commit(self) -> None:
        """The staged run into place; on any failure (a file that will not move, Ctrl-C) every
        move made is undone: the folder holds the new run whole or the previous one as it was
        (one immutable file left the previous run split between the folder and .previous)."""
        out, stage = self.out, self.stage
        if self.inside:  # file by file into the folder, the stage inside it
            self._commit_inside()
            return
        # the folder coplan runs in (``-o .``; ``out_dir=Path('')`` from the library) is never removed or renamed: file by file
        in_place = not out.name or out.absolute() == Path.cwd().absolute()
        if not in_place and out.is_dir() and not any(out.iterdir()):
            out.rmdir()
            try:
                stage.rename(out)
            except BaseException:
                out.mkdir(exist_ok=True)
                raise
            return
        if not in_place and is_run_folder(out):
            prev, older = _cleared_previous(out)
            out.rename(prev)
            try:
                stage.rename(out)
            except BaseException:
                if not out.exists():
                    prev.rename(out)
                _restore(older, prev)
                raise
            _drop(older)
            self.previous = prev
            return
        if not out.exists():
            stage.rename(out)
            return
        # a folder with the user's own files in it: theirs stay, coplan's are replaced, one by one
        moved: list[tuple[Path, Path]] = []
        ours = [p for p in sorted(out.iterdir()) if _ours(p)]
        prev = older = None
        try:
            if ours:  # the previous run's files go to <name>.previous whole (none left beside the new run's)
                prev, older = _cleared_previous(out)
                prev.mkdir()
                for f in ours:
                    os.replace(f, prev / f.name)
                    moved.append((f, prev / f.name))
            for f in sorted(stage.iterdir()):
                os.replace(f, out / f.name)
                moved.append((f, out / f.name))
        except BaseException:
            for src, dst in reversed(moved):
                os.replace(dst, src)
            if prev is not None and prev.is_dir() and not any(prev.iterdir()):
                prev.rmdir()
            _restore(older, prev)
            raise
        _drop(older)
        self.previous = prev
        _drop_empty(stage)  # (the run is in place: an empty stage that will not go is no failure)

    def _commit_inside(self) -> None:
        """The staged files into ``out``, where the stage is (nothing may be made beside it): a
        previous run there, which would be overwritten with nowhere to keep it, is refused (as
        :func:`check_folder` refused it before the work; one made since)."""
        out, stage = self.out, self.stage
        held = [p for p in out.iterdir() if p != stage and _ours(p)]
        if held:
            raise OutputError(f"{out}: a run was written there meanwhile ({held[0].name}), and nothing may be made beside "
                              f"the folder to keep it in: this run is not written")
        moved: list[Path] = []
        try:
            for f in sorted(stage.iterdir()):
                os.replace(f, out / f.name)
                moved.append(out / f.name)
        except BaseException:
            for dst in reversed(moved):
                os.replace(dst, stage / dst.name)
            raise
        _drop_empty(stage)  # (the run is in place: an empty stage that will not go is no failure)


def _drop_empty(stage: Path) -> None:
    """The emptied staging folder removed; left (hidden, empty) where the system refuses."""
    try:
        stage.rmdir()
    except OSError:
        pass


def _restore(older: Path | None, prev: Path | None) -> None:
    """An older previous run set aside by :func:`_cleared_previous` back in place (a commit failed)."""
    if older is not None and prev is not None and not prev.exists():
        older.rename(prev)
        shutil.rmtree(older.parent, ignore_errors=True)  # (the hidden folder it was set aside in)


def _drop(older: Path | None) -> None:
    """An older previous run set aside, removed (the commit succeeded)."""
    if older is not None:
        shutil.rmtree(older.parent, ignore_errors=True)  # (the hidden folder it was set aside in)


def _cleared_previous(out: Path) -> tuple[Path, Path | None]:
    """``(<out>.previous, where an older previous run there was set aside or None)``: the older
    one is removed once the commit succeeds (:func:`_drop`), put back if it fails
    (:func:`_restore`). When something else is there (made since :func:`check_folder` looked),
    the first free ``<out>.previous.<n>``: nothing of the user's is removed."""
    prev = previous_of(out)
    if _replaceable(prev):
        older = None
        if prev.is_dir():
            older = Path(tempfile.mkdtemp(prefix=f".{prev.name}.", suffix=".old", dir=prev.parent))
            os.replace(prev, older / prev.name)
            older = older / prev.name
        return prev, older
    n = 1
    while prev.with_name(f"{prev.name}.{n}").exists():
        n += 1
    return prev.with_name(f"{prev.name}.{n}"), None
