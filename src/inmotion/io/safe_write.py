"""Writes that are whole or absent: files and folders are written beside, then renamed.

- :func:`atomic_write` writes one file under a temporary name in the same folder and renames
  it onto the target (``os.replace``, atomic on POSIX). The file gets the user's normal
  permissions (``0666`` less the umask), not the ``0600`` of ``tempfile.mkstemp``.
- :func:`staged_folder` builds a whole folder (a bundle, a result) as a hidden sibling
  ``.NAME.XXXXXXXX.partial`` holding the marker file :data:`PARTIAL_MARKER`; on success the
  marker is removed and the sibling takes the target's place in one ``renameat2(...,
  RENAME_EXCHANGE)`` (Linux; elsewhere two renames), after which the old folder is deleted.
  Killed at any moment, the target holds either its old content, untouched, or the new one,
  complete. Files of the old folder that the writer does not replace are carried over (hard
  links, else copies), so other files a user put there survive.
- :func:`refuse_partial` is what readers call: a folder holding the marker is a writer's
  unfinished work and is refused with :class:`inmotion.errors.BadInput`.
- :func:`output_error` turns an ``OSError`` of a write (no permission, a path under a regular
  file, a name too long, a full disk ...) into one ``BadInput`` line naming the path.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import stat
import uuid
from pathlib import Path

from ..errors import BadInput

__all__ = ["atomic_write", "staged_folder", "refuse_partial", "output_error", "PARTIAL_MARKER",
           "check_output_path"]

#: a file in a folder that a writer has not finished
PARTIAL_MARKER = ".inmotion-partial"


def output_error(path, e: OSError, what: str = "cannot write") -> BadInput:
    """A one-line :class:`BadInput` for an ``OSError`` raised while writing ``path``."""
    reason = {errno.ENAMETOOLONG: "the name is too long",
              errno.ENOTDIR: "a part of the path is a file, not a folder",
              errno.EACCES: "permission denied", errno.EPERM: "permission denied",
              errno.EROFS: "read-only file system", errno.ENOSPC: "no space left on the device",
              errno.EDQUOT: "disk quota exceeded", errno.EEXIST: "exists and is in the way",
              errno.EISDIR: "is a folder"}.get(e.errno, e.strerror or type(e).__name__)
    return BadInput(f"{what}: {reason}", file=path)


def check_output_path(path, folder: bool = True, kind: str | None = None) -> Path:
    """Refuse an output path that cannot be written (before any work is done): a dangling
    symbolic link, a file where a folder is wanted (or the reverse), a name longer than the
    file system allows, a parent that is a file or not writable; with ``kind`` ("bundle",
    "result"), an existing folder that is not one of that kind (see :func:`staged_folder`)."""
    p = Path(path)
    if str(path) == "":
        raise BadInput("the output path is empty")
    try:
        limit = os.pathconf(_existing_ancestor(p.parent), "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for part in p.parts:
        if len(os.fsencode(part)) > limit:
            raise BadInput(f"the name {part[:40]}... is too long ({len(os.fsencode(part))} "
                           f"bytes; the file system allows {limit})", file=p)
    if p.is_symlink() and not p.exists():
        raise BadInput(f"is a dangling symbolic link (to {os.readlink(p)}); remove it or "
                       "choose another output", file=p)
    if folder and p.exists() and not p.is_dir():
        raise BadInput("exists and is not a folder", file=p)
    if not folder and p.is_dir():
        raise BadInput("is a folder; give a file name", file=p)
    anc = _existing_ancestor(p.parent)
    if not anc.is_dir():
        raise BadInput(f"{anc} is a file, not a folder", file=p)
    if not os.access(anc, os.W_OK | os.X_OK) and not (p.exists() and folder
                                                     and os.access(p, os.W_OK)):
        raise BadInput(f"no permission to write in {anc}", file=p)
    if kind is not None:
        _check_replaceable(p.resolve() if p.is_symlink() else p, kind)
    return p


def _existing_ancestor(p: Path) -> Path:
    p = Path(os.path.abspath(p))
    while p != p.parent:
        try:
            if os.path.lexists(p):
                return p
        except OSError:
            pass
        p = p.parent
    return p


def _tmp_name(target: Path, suffix: str) -> Path:
    stem = target.name[:60]
    return target.with_name(f".{stem}.{uuid.uuid4().hex[:8]}{suffix}")


def atomic_write(target, write) -> None:
    """Call ``write(tmp_path)`` then rename ``tmp_path`` onto ``target``.

    The temporary file is created with the user's normal permissions; an ``OSError`` (no
    permission, a name too long, a path under a file ...) becomes :class:`BadInput`."""
    target = Path(target)
    tmp = _tmp_name(target, ".tmp")
    try:
        write(tmp)
        os.replace(tmp, target)
    except OSError as e:
        _unlink(tmp)
        raise output_error(target, e) from None
    except BaseException:
        _unlink(tmp)
        raise


def _unlink(p) -> None:
    with contextlib.suppress(OSError):
        os.unlink(p)


def refuse_partial(folder, what: str = "folder") -> None:
    """:class:`BadInput` if ``folder`` is a writer's unfinished work (holds the marker)."""
    if (Path(folder) / PARTIAL_MARKER).exists():
        raise BadInput(f"a half-written {what} (its writer was interrupted); write it again",
                       file=folder)


def _exchange(a: Path, b: Path) -> bool:
    """Swap the names ``a`` and ``b`` atomically (Linux ``renameat2``); False if unsupported."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    AT_FDCWD, RENAME_EXCHANGE = -100, 2
    if fn(AT_FDCWD, os.fsencode(str(a)), AT_FDCWD, os.fsencode(str(b)), RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _remove_stale(target: Path) -> None:
    """Delete the unfinished siblings of ``target`` that killed writers left (their process,
    named in the marker, is gone); a live writer's sibling is left alone."""
    for p in target.parent.glob(f".{glob_escape(target.name[:60])}.*.partial"):
        try:
            pid = int((p / PARTIAL_MARKER).read_text().split("\n", 1)[0].partition("=")[2])
        except (OSError, ValueError):
            continue
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(p, ignore_errors=True)
        except OSError:
            pass


def glob_escape(name: str) -> str:
    import glob
    return glob.escape(name)


def _carry_over(src: Path, dst: Path) -> None:
    """Hard-link (else copy) what ``src`` holds into ``dst``, skipping the marker."""
    for entry in os.scandir(src):
        s, d = Path(entry.path), dst / entry.name
        if entry.name == PARTIAL_MARKER:
            continue
        if entry.is_dir(follow_symlinks=False):
            shutil.copytree(s, d, symlinks=True, copy_function=_link_or_copy)
        elif entry.is_symlink():
            os.symlink(os.readlink(s), d)
        else:
            _link_or_copy(s, d)


def _link_or_copy(s, d):
    try:
        os.link(s, d)
    except OSError:
        shutil.copy2(s, d)


#: files that make an existing folder one this package may replace, per kind of folder
OWNED_BY = {"bundle": ("meta.yaml",), "result": ("summary.json", "solution.csv")}


def _check_replaceable(target: Path, what: str) -> None:
    """An existing, non-empty folder is replaced only if it is a folder of this kind (a bundle
    with its ``meta.yaml``, a result with its ``summary.json``...), never a user's unrelated
    folder (a home, ``/tmp``, a project), nor a mount point."""
    if not target.is_dir():
        return
    if os.path.ismount(target):
        raise BadInput(f"is a mount point; write the {what} into a folder inside it",
                       file=target)
    try:
        empty = not any(os.scandir(target))
    except OSError as e:
        raise output_error(target, e, "cannot read") from None
    marks = OWNED_BY.get(what)
    if empty or marks is None or any((target / m).exists() for m in marks):
        return
    raise BadInput(f"exists and holds other files but is not a {what} folder (no "
                   f"{' or '.join(marks)}); write into a new or empty folder", file=target)


@contextlib.contextmanager
def staged_folder(target, keep_existing: bool = True, what: str = "folder"):
    """Build the folder ``target`` in a hidden sibling and put it in place whole on success.

    Yields the sibling's path; everything written into it must go through
    :func:`atomic_write` (or be new files), since carried-over files are hard links to the
    old folder's. On an exception the sibling is deleted and ``target`` is left as it was.
    An existing non-empty folder is replaced only if it is of the kind ``what`` (see
    :data:`OWNED_BY`); it keeps its permissions.
    """
    target = check_output_path(target, folder=True)
    if target.is_symlink():
        target = target.resolve()
    _check_replaceable(target, what)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = _tmp_name(target, ".partial")
        os.mkdir(tmp)
    except OSError as e:
        raise output_error(target, e) from None
    try:
        (tmp / PARTIAL_MARKER).write_text(f"pid={os.getpid()}\nwritten by inmotion; "
                                          "unfinished while this file exists\n")
        _remove_stale(target)
        if target.is_dir():
            os.chmod(tmp, stat.S_IMODE(os.stat(target).st_mode))
            if keep_existing:
                _carry_over(target, tmp)
        yield tmp
        os.unlink(tmp / PARTIAL_MARKER)
        if target.exists():
            if not _exchange(tmp, target):
                old = _tmp_name(target, ".old")
                os.rename(target, old)
                os.rename(tmp, target)
                tmp = old
            shutil.rmtree(tmp, ignore_errors=True)       # now the old content
        else:
            os.rename(tmp, target)
    except OSError as e:
        shutil.rmtree(tmp, ignore_errors=True)
        raise output_error(target, e) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
