"""Files of a results folder, written and deleted without following symbolic links (issue 34, item 2).

Every file that ``run``, ``plot``, ``point`` and ``study`` write or delete goes through these functions,
so that an output folder cannot be used to reach outside it: a symbolic link (to a file, to a folder,
dangling, a chain), a FIFO or a device at a name the run writes is refused (:class:`LinkRefused`, naming
the path), never written through, and a hard link is never written into (the name is unlinked and
created anew, ``O_EXCL``).

``path`` lies in ``root`` (the folder the user named, e.g. ``--out``, which may itself be reached
through a link: it is the user's choice) or, without ``root``, in ``path.parent``; every folder
between ``root`` and the file (``checkpoint/``, ``runs/<name>/``) is opened with ``O_NOFOLLOW``.

* :func:`open_write`: a new regular file (an existing one is replaced, not truncated in place);
* :func:`write_atomic`: a temporary name (``O_EXCL``), fsync, ``os.replace``;
* :func:`remove_file`: unlink a regular file (a link or anything else is left alone);
* :func:`make_dir`: create a folder (or use the one there), refusing a link;
* :func:`link_at`: the first symbolic link among some names of a folder (the up-front checks).
"""
from __future__ import annotations

import errno
import fcntl
import os
import stat
from pathlib import Path

__all__ = ["LinkRefused", "open_write", "write_atomic", "remove_file", "make_dir", "link_at", "is_link"]

_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_DIR = os.O_RDONLY | os.O_DIRECTORY | _CLOEXEC


class LinkRefused(OSError):
    """A symbolic link, or something else than a regular file or folder, where fenics-plast writes or
    deletes: refused, nothing written there (the CLI exits 2)."""


def _refuse(path, what: str) -> LinkRefused:
    return LinkRefused(f"{path}: {what}: fenics-plast does not write or delete through it (its results stay inside "
                       f"the output folder); remove it, or choose another output folder")


def _describe(st) -> str:
    if stat.S_ISLNK(st.st_mode):
        return "is a symbolic link"
    if stat.S_ISDIR(st.st_mode):
        return "is a folder, not a file"
    return "is not a regular file (a FIFO, socket or device)"


def _lstat(name, dir_fd):
    try:
        return os.lstat(name, dir_fd=dir_fd)
    except FileNotFoundError:
        return None


def _parent(path, root=None) -> tuple[int, str]:
    """(an open descriptor of the folder that holds ``path``, the file's name): the folders below
    ``root`` are opened without following links."""
    path = Path(path)
    if root is None:
        base, parts = path.parent, [path.name]
    else:
        base, parts = Path(root), list(path.relative_to(root).parts)
    if not parts or parts[-1] in ("", ".", ".."):
        raise _refuse(path, "is not a file name")
    fd = os.open(base, _DIR)
    try:
        for i, part in enumerate(parts[:-1]):
            if part in (".", ".."):
                raise _refuse(path, "leaves the folder")
            try:
                nfd = os.open(part, _DIR | os.O_NOFOLLOW, dir_fd=fd)
            except OSError as e:
                st = _lstat(part, fd)
                if st is not None and not stat.S_ISDIR(st.st_mode):
                    raise _refuse(base.joinpath(*parts[: i + 1]), _describe(st)) from None
                raise
            os.close(fd)
            fd = nfd
    except BaseException:
        os.close(fd)
        raise
    return fd, parts[-1]


def _check_name(path, name, fd, want_dir=False) -> os.stat_result | None:
    st = _lstat(name, fd)
    if st is not None and not (stat.S_ISDIR(st.st_mode) if want_dir else stat.S_ISREG(st.st_mode)):
        raise _refuse(path, _describe(st) if not want_dir or stat.S_ISLNK(st.st_mode) else "is not a folder")
    return st


def _create(fd: int, name: str, path) -> int:
    """A new regular file ``name`` in folder ``fd`` (an existing regular file is unlinked first)."""
    if _check_name(path, name, fd) is not None:
        os.unlink(name, dir_fd=fd)
    try:
        return os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | _CLOEXEC, 0o666, dir_fd=fd)
    except FileExistsError:         # something appeared there meanwhile
        st = _lstat(name, fd)
        raise _refuse(path, _describe(st) if st else "appeared while it was written") from None


def open_write(path, root=None, mode: str = "w", append: bool = False, **kwargs):
    """``open(path, mode)`` for writing a regular file, links refused: a new file (any earlier one is
    unlinked, so a hard link elsewhere is not written into); ``append``: the existing regular file, at its
    end. ``kwargs`` go to :func:`open` (encoding, newline)."""
    fd, name = _parent(path, root)
    try:
        if append:
            _check_name(path, name, fd)
            try:
                f = os.open(name, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK
                            | _CLOEXEC, 0o666, dir_fd=fd)
            except OSError as e:
                if e.errno in (errno.ELOOP, errno.ENXIO):
                    raise _refuse(path, "is not a regular file") from None
                raise
            st = os.fstat(f)
            if not stat.S_ISREG(st.st_mode):
                os.close(f)
                raise _refuse(path, _describe(st))
            fcntl.fcntl(f, fcntl.F_SETFL, fcntl.fcntl(f, fcntl.F_GETFL) & ~os.O_NONBLOCK)
        else:
            f = _create(fd, name, path)
    finally:
        os.close(fd)
    return open(f, mode, **kwargs)


def write_atomic(path, data: bytes | str, root=None, fsync: bool = True) -> None:
    """Write ``data`` (str: UTF-8) to ``path`` through a temporary name in the same folder (created with
    ``O_EXCL``): write, fsync, ``os.replace``, fsync of the folder. A crash leaves the old file or the new
    one, never a partial one; a link at ``path`` is refused before anything is written."""
    if isinstance(data, str):
        data = data.encode("utf-8")
    fd, name = _parent(path, root)
    try:
        _check_name(path, name, fd)
        tmp = f".{name}.tmp{os.getpid()}"
        if len(tmp) > 255:
            tmp = f".tmp{os.getpid()}.{name[-200:]}"
        remove_file(tmp, dir_fd=fd)
        f = _create(fd, tmp, Path(path).with_name(tmp))
        try:
            with open(f, "wb") as fh:
                fh.write(data)
                fh.flush()
                if fsync:
                    os.fsync(fh.fileno())
            _check_name(path, name, fd)
            os.replace(tmp, name, src_dir_fd=fd, dst_dir_fd=fd)
        except BaseException:
            remove_file(tmp, dir_fd=fd)
            raise
        if fsync:
            try:
                os.fsync(fd)
            except OSError:
                pass
    finally:
        os.close(fd)


def remove_file(path, root=None, dir_fd: int | None = None) -> bool:
    """Unlink ``path`` when it is a regular file (True); a link, a folder or anything else is left
    alone, and a missing file is fine (False). ``dir_fd``: ``path`` is a name in that open folder."""
    if dir_fd is not None:
        st = _lstat(path, dir_fd)
        if st is None or not stat.S_ISREG(st.st_mode):
            return False
        try:
            os.unlink(path, dir_fd=dir_fd)
        except FileNotFoundError:
            return False
        return True
    try:
        fd, name = _parent(path, root)
    except (FileNotFoundError, NotADirectoryError, LinkRefused):
        return False
    try:
        return remove_file(name, dir_fd=fd)
    finally:
        os.close(fd)


def make_dir(path, root=None) -> None:
    """Create the folder ``path`` (its parent must exist) or keep the real folder there; a link (or a
    file) at ``path`` is refused."""
    fd, name = _parent(path, root)
    try:
        try:
            os.mkdir(name, dir_fd=fd)
        except FileExistsError:
            _check_name(path, name, fd, want_dir=True)
    finally:
        os.close(fd)


def is_link(path) -> bool:
    """Whether ``path`` itself is a symbolic link (dangling ones too)."""
    try:
        return stat.S_ISLNK(os.lstat(path).st_mode)
    except OSError:
        return False


def link_at(folder, names) -> Path | None:
    """The first of ``names`` (relative paths) in ``folder`` that is, or lies below, a symbolic link or
    something else than a regular file or folder; None when there is none."""
    folder = Path(folder)
    for name in names:
        p = folder
        for part in Path(name).parts:
            p = p / part
            try:
                st = os.lstat(p)
            except OSError:
                break
            if not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)):
                return p
            if not stat.S_ISDIR(st.st_mode):
                break
    return None
