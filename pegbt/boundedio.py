"""Reading files a user names without trusting them: regular files only, sizes bounded before reading.

Why: a reader that reads a file whole and then checks it dies of MemoryError on `/dev/zero`, hangs
on a FIFO, and lets a NumPy header that claims 44 GiB allocate it. Every reader of user files goes
through `file_size` (what the file is, before it is opened) and `read_bytes` or `map_npy` (never
more than the limit), so a bad file is a `PegbtError` naming it, never a hang or a traceback;
nor a SIGBUS when another program truncates it while it is used (`map_npy` maps a private copy).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from pegbt.errors import PegbtError

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

_NPY_MAGIC = b"\x93NUMPY"


def file_size(path: str | os.PathLike[str], limit: int, what: str = "file") -> int:
    """The size of `path` if it is a regular file of at most `limit` bytes; else a `PegbtError`."""
    try:
        status = os.stat(path)
    except FileNotFoundError:
        raise PegbtError(f"{what} not found", file=path) from None
    except OSError as error:
        reason = "a part of the path is too long" if error.errno == errno.ENAMETOOLONG else error.strerror
        raise PegbtError(f"cannot read the {what}: {reason}", file=path) from None
    except ValueError as error:  # an embedded NUL byte
        raise PegbtError(f"cannot read the {what}: {error}", file=path) from None
    if stat.S_ISDIR(status.st_mode):
        raise PegbtError(f"expected a {what}, found a folder", file=path)
    if not stat.S_ISREG(status.st_mode):
        raise PegbtError(f"expected a regular {what}, found a device, FIFO or socket", file=path)
    if status.st_size > limit:
        raise PegbtError(f"{what} is {status.st_size} bytes; the limit is {limit} bytes", file=path)
    return status.st_size


def read_bytes(path: str | os.PathLike[str], limit: int, what: str = "file") -> bytes:
    """The contents of a regular file of at most `limit` bytes (checked before and while reading)."""
    file_size(path, limit, what)
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)
    except OSError as error:
        raise PegbtError(f"cannot read the {what}: {error.strerror}", file=path) from None
    if len(data) > limit:
        raise PegbtError(f"{what} grew past the limit of {limit} bytes while being read", file=path)
    return data


COPY_BYTES = 2**20  # read at a time into a recording array's private copy


def map_npy(path: Path, limit: int) -> NDArray[np.floating]:
    """A floating-point `.npy` array whose header, read first, promises at most `limit` bytes of data,
    mapped read-only from a private copy: an unnamed temporary file its data is copied into with
    positional reads. Its pages are the kernel's to read in and drop, not the process's own memory, so an
    hour of recording costs what its chunks in use do; and a recording truncated or rewritten while it is
    diagnosed cannot end the process with SIGBUS, as a mapping of the file itself would (a page past the
    file's new end): the copy is what the file held when it was read, or a `PegbtError` naming the file
    when it changed while it was copied.

    Integers (a recording in counts or ticks), complex numbers (whose imaginary part a cast drops),
    timedeltas, objects and zip archives (`.npz` named `.npy`) are refused, never cast."""
    import numpy as np  # here, not at the top: the YAML readers share this module and need no NumPy

    file_size(path, limit + 4096, "NumPy file")
    try:
        with open(path, "rb") as handle:
            shape, fortran, dtype = _npy_header(path, handle)
            before = os.fstat(handle.fileno())
            size = before.st_size
            count = int(np.prod(shape, dtype=object))
            claimed = count * dtype.itemsize
            if not stat.S_ISREG(before.st_mode) or claimed > limit or claimed > size - handle.tell():
                raise PegbtError(
                    f"the header claims {claimed} bytes of data for shape {shape}, but the file holds "
                    f"{size - handle.tell()} (limit {limit})",
                    file=path,
                )
            if count == 0 or not shape:  # nothing to map (mmap refuses an empty mapping), or one number
                return np.fromfile(handle, dtype=dtype, count=count).reshape(shape)
            with tempfile.TemporaryFile(prefix="pegbt-npy-") as copy:
                _copy_data(path, handle.fileno(), handle.tell(), claimed, before, copy)
                return np.asarray(
                    np.memmap(copy, dtype=dtype, mode="r", shape=shape, order="F" if fortran else "C")
                )  # an ordinary array over the mapping, which keeps the copy open
    except PegbtError:
        raise
    except (OSError, ValueError, EOFError, SyntaxError, TypeError) as error:
        raise PegbtError(f"cannot read it as a NumPy array ({error})", file=path) from None


def _npy_header(path: Path, handle: BinaryIO) -> tuple[tuple[int, ...], bool, np.dtype]:
    """(shape, Fortran order, dtype) of a floating-point `.npy` file's header, leaving `handle` at its data."""
    import numpy as np

    if handle.read(len(_NPY_MAGIC)) != _NPY_MAGIC:
        raise PegbtError(
            "cannot read it as a NumPy array: no .npy header (an .npz archive, or another format?)", file=path
        )
    handle.seek(0)
    version = np.lib.format.read_magic(handle)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(handle)
    elif version in ((2, 0), (3, 0)):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(handle)
    else:
        raise PegbtError(f"unsupported .npy format version {version}", file=path)
    if dtype.kind != "f" or dtype.hasobject:
        raise PegbtError(
            f"holds {dtype} values; joints and times must be floating point (rad, m, s)", file=path
        )
    return shape, fortran, dtype


def _copy_data(
    path: Path, source: int, offset: int, length: int, before: os.stat_result, copy: BinaryIO
) -> None:
    """Copy `length` bytes from `offset` of the open file `source` into `copy`, `COPY_BYTES` at a time by
    positional reads, checking after each that the file is the one `before` described: the same size and
    modification time (a truncation, or a rewrite in place, while it is copied is a `PegbtError`)."""
    buffer = memoryview(bytearray(min(COPY_BYTES, length)))
    done = 0
    try:
        while done < length:
            want = min(len(buffer), length - done)
            got = os.preadv(source, [buffer[:want]], offset + done)
            now = os.fstat(source)
            if got < want or (now.st_size, now.st_mtime_ns) != (before.st_size, before.st_mtime_ns):
                raise PegbtError(
                    f"changed while it was read: {before.st_size} bytes when opened, {now.st_size} after "
                    f"{offset + done + got} were read; read it again once whatever writes it is done",
                    file=path,
                )
            copy.write(buffer[:got])
            done += got
        copy.flush()
    except OSError as error:
        if error.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        raise PegbtError(
            f"no room for its private copy in the temporary folder {tempfile.gettempdir()} ({error.strerror})",
            file=path,
        ) from None
