"""A dataset file and its pending parts: scan, pack, delete and read episodes, never damaging a file.

HDF5 is not crash-safe for in-place appends, so episodes are never appended in place. A
recording run writes each finished episode to its own file ``FILE.h5.parts/episode_XXXXXX.h5``
(written as ``*.tmp``, fsynced, then ``os.replace``'d). :func:`pack` writes ``FILE.h5.tmp`` =
the episodes of ``FILE.h5`` followed by the parts, fsyncs it, ``os.replace``'s it onto
``FILE.h5`` and only then deletes the parts. A crash at any point leaves either the old or the
new ``FILE.h5``, complete, plus complete parts; parts already packed (a crash between the
replace and the clean-up) are recognised by their episode ``uid`` and dropped.

Every reader here opens files read-only; every writer writes a temporary file and replaces
the target only after everything it needs has been read and checked, so a failing command
leaves the file's bytes unchanged. A run that adds to or rewrites a file holds its lock
(:func:`writing`), so a second run on the same file stops before it touches anything.
"""

from __future__ import annotations

import fcntl
import os
import re
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from pipette_cli.demos.recorder import (
    EPISODES,
    DatasetInfo,
    EpisodeSummary,
    commit_tmp,
    episode_name,
    fsync_dir,
    fsync_file,
    read_summary,
)
from pipette_cli.errors import DatasetError, plural

PART_PATTERN = re.compile(r"^episode_(\d{6,})\.h5$")
_READ_ERRORS = (OSError, KeyError, ValueError, RuntimeError, TypeError)


def parts_dir(path: Path) -> Path:
    """Folder of the finished-but-not-yet-packed episodes of ``path``."""
    return path.with_name(path.name + ".parts")


def part_path(path: Path, index: int) -> Path:
    return parts_dir(path) / f"{episode_name(index)}.h5"


def lock_path(path: Path) -> Path:
    """The file a writer of ``path`` holds locked (:func:`writing`) while it writes."""
    return path.with_name(path.name + ".lock")


@contextmanager
def writing(*paths: Path) -> Iterator[None]:
    """Hold every ``paths``' writer lock for the block; a second writer fails at once, saying who holds it.

    Two runs appending to one file at once would race on its parts (both number them from the same count).
    The lock is ``flock`` on ``FILE.h5.lock`` (released when the process ends, however it ends); the file
    holds the writer's pid and is removed when the block ends.
    """
    with ExitStack() as stack:
        held: set[Path] = set()
        for path in map(Path, paths):
            if path.absolute() not in held:  # the same file named twice is locked once
                held.add(path.absolute())
                stack.enter_context(_locked(path))
        yield


@contextmanager
def _locked(path: Path) -> Iterator[None]:
    lock = lock_path(path)
    made = [f for f in (lock.parent, *lock.parent.parents) if not f.exists()]  # deepest first
    lock.parent.mkdir(parents=True, exist_ok=True)
    while True:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise DatasetError(
                f"{path} is being written by another run (pid {holder}, lock {lock}); "
                "wait for it to finish, or write to another file"
            ) from None
        try:
            if os.stat(lock).st_ino == os.fstat(fd).st_ino:
                break
        except FileNotFoundError:
            pass
        os.close(fd)  # the holder removed the file between our open and our lock: lock the new one
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        lock.unlink(missing_ok=True)
        os.close(fd)
        for folder in made:  # a folder made for the lock alone goes with it (a run that failed early)
            try:
                folder.rmdir()
            except OSError:
                break


def _tmp(path: Path) -> Path:
    return path.with_name(path.name + ".tmp")


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    inner = re.search(r"\(([^()]*)\)\s*$", text)
    return inner.group(1) if inner else text[:200]


@contextmanager
def open_h5(path: Path) -> Iterator[h5py.File]:
    """Open ``path`` read-only; turn every way it can be unreadable into one clear :class:`DatasetError`."""
    if not path.exists():
        raise DatasetError(f"{path}: no such file")
    if path.is_dir():
        raise DatasetError(f"{path} is a folder, not an HDF5 file")
    try:
        f = h5py.File(path, "r")
    except _READ_ERRORS as exc:
        raise DatasetError(f"{path} is not a readable HDF5 file ({_reason(exc)}); it is corrupt or truncated") from None
    try:
        yield f
    except DatasetError:
        raise
    except _READ_ERRORS as exc:
        raise DatasetError(f"{path} is damaged: {_reason(exc)}") from None
    finally:
        f.close()


@dataclass(frozen=True)
class EpisodeRef:
    """Where episode ``index`` of a dataset lives: the file itself or a pending part."""

    index: int
    file: Path
    group: str
    summary: EpisodeSummary
    pending: bool


@dataclass
class DatasetStatus:
    """A dataset file and its parts as found on disk."""

    path: Path
    info: DatasetInfo | None
    packed: list[EpisodeRef] = field(default_factory=list)
    pending: list[EpisodeRef] = field(default_factory=list)
    stale: list[Path] = field(default_factory=list)
    """Parts already contained in the file (left by a crash after packing)."""
    leftovers: list[Path] = field(default_factory=list)
    """Unfinished ``*.tmp`` files of an interrupted run or pack."""

    @property
    def episodes(self) -> list[EpisodeRef]:
        return self.packed + self.pending

    @property
    def seeds(self) -> set[int]:
        return {ref.summary.seed for ref in self.episodes}

    def episode(self, index: int) -> EpisodeRef:
        total = len(self.episodes)
        if not 0 <= index < total:
            valid = f"0..{total - 1}" if total else "none"
            raise DatasetError(
                f"episode {index} is out of range: {self.path} has {plural(total, 'episode')} (valid: {valid})"
            )
        return self.episodes[index]


def _read_file(path: Path, *, part: bool = False) -> tuple[DatasetInfo, list[tuple[str, EpisodeSummary]]]:
    with open_h5(path) as f:
        info = DatasetInfo.read(f.attrs, str(path))
        group = f.get(EPISODES)
        if not isinstance(group, h5py.Group):
            raise DatasetError(f"{path} is damaged: it has no {EPISODES!r} group")
        names = sorted(group)
        expected = [episode_name(i) for i in range(len(names))]
        if part and len(names) != 1:
            raise DatasetError(f"{path} is damaged: a part holds exactly one episode, not {len(names)}")
        if not part and names != expected:
            raise DatasetError(f"{path} is damaged: episode groups {names[:5]} are not numbered 0..{len(names) - 1}")
        return info, [(name, read_summary(group[name])) for name in names]


def scan(path: Path) -> DatasetStatus:
    """Read the file's attributes and episode summaries, and those of its pending parts.

    Raises:
        DatasetError: the file or a part is unreadable, not a Pipette file, or a part belongs
            to another task or image size than the file.
    """
    path = Path(path)
    status = DatasetStatus(path, None)
    uids: set[str] = set()
    if path.exists():
        info, episodes = _read_file(path)
        status.info = info
        for name, summary in episodes:
            status.packed.append(EpisodeRef(len(status.packed), path, f"{EPISODES}/{name}", summary, False))
            uids.add(summary.uid)
    folder = parts_dir(path)
    if folder.is_dir():
        numbered = []
        for child in folder.iterdir():
            match = PART_PATTERN.match(child.name)
            if match:
                numbered.append((int(match.group(1)), child))
            elif child.name.endswith(".tmp"):
                status.leftovers.append(child)
        for _, part in sorted(numbered):
            info, episodes = _read_file(part, part=True)
            if status.info is None:
                status.info = info
            elif (why := status.info.mismatch(info)) is not None:
                raise DatasetError(f"{part} cannot join {path}: {why}")
            for name, summary in episodes:
                if summary.uid in uids:
                    status.stale.append(part)
                    continue
                uids.add(summary.uid)
                status.pending.append(EpisodeRef(len(status.episodes), part, f"{EPISODES}/{name}", summary, True))
    if _tmp(path).exists():
        status.leftovers.append(_tmp(path))
    return status


def clean(status: DatasetStatus) -> None:
    """Delete stale parts and unfinished temporary files (never a complete episode)."""
    for leftover in [*status.stale, *status.leftovers]:
        leftover.unlink(missing_ok=True)
    status.stale.clear()
    status.leftovers.clear()


def _write_file(target: Path, info: DatasetInfo, sources: list[EpisodeRef]) -> None:
    """Write ``sources`` as episodes 0..n-1 of a new file at ``target`` + ``.tmp``, then replace ``target``."""
    tmp = _tmp(target)
    tmp.unlink(missing_ok=True)
    try:
        with h5py.File(tmp, "w") as dst:
            info.write(dst.attrs)
            episodes = dst.create_group(EPISODES)
            by_file: dict[Path, list[tuple[int, EpisodeRef]]] = {}
            for new_index, ref in enumerate(sources):
                by_file.setdefault(ref.file, []).append((new_index, ref))
            for file, refs in by_file.items():
                with open_h5(file) as src:
                    for new_index, ref in refs:
                        name = episode_name(new_index)
                        src.copy(src[ref.group], episodes, name=name)
                        episodes[name].attrs["index"] = new_index
        fsync_file(tmp)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    commit_tmp(tmp, target)


def pack(path: Path) -> int:
    """Move pending parts into ``path`` atomically; returns how many episodes were packed."""
    status = scan(path)
    clean(status)
    if status.pending:
        assert status.info is not None
        _write_file(path, status.info, status.episodes)
        for ref in status.pending:
            ref.file.unlink(missing_ok=True)
    folder = parts_dir(path)
    if folder.is_dir() and not any(folder.iterdir()):
        folder.rmdir()
        fsync_dir(folder.parent)
    return len(status.pending)


def delete_episode(path: Path, index: int) -> EpisodeSummary:
    """Remove episode ``index`` (later episodes move down by one); the file is rewritten atomically."""
    with writing(path):
        return _delete_episode(path, index)


def _delete_episode(path: Path, index: int) -> EpisodeSummary:
    status = scan(path)
    if not path.exists():
        raise DatasetError(f"{path}: no such file")
    if status.pending:
        raise DatasetError(
            f"{path} has {plural(len(status.pending), 'episode')} of an interrupted run pending in {parts_dir(path)}; "
            f"run `pipette data pack {path}` first"
        )
    ref = status.episode(index)
    assert status.info is not None
    _write_file(path, status.info, [r for r in status.packed if r.index != index])
    return ref.summary


@dataclass
class EpisodeRecord:
    """One episode's arrays (images only when asked for) and attributes."""

    summary: EpisodeSummary
    attrs: dict[str, object]
    arrays: dict[str, np.ndarray]
    images: dict[str, np.ndarray]


def read_episode(ref: EpisodeRef, *, images: bool | Sequence[str] = False) -> EpisodeRecord:
    """Load an episode's datasets into memory, with every camera's images (``images=True``), only
    those of the cameras named, or none."""
    with open_h5(ref.file) as f:
        group = f[ref.group]
        arrays = {name: group[name][()] for name in group if isinstance(group[name], h5py.Dataset)}
        recorded = list(group.get("images", {})) if images else []
        wanted = [c for c in recorded if isinstance(images, bool) or c in images]
        pictures = {cam: group["images"][cam][()] for cam in wanted}
        attrs = {key: (value.item() if isinstance(value, np.generic) else value) for key, value in group.attrs.items()}
        return EpisodeRecord(ref.summary, attrs, arrays, pictures)


def file_size(path: Path) -> int:
    """Bytes of the file plus its pending parts."""
    total = path.stat().st_size if path.exists() else 0
    folder = parts_dir(path)
    if folder.is_dir():
        total += sum(p.stat().st_size for p in folder.iterdir() if p.is_file())
    return total


def episode_arrays(ref: EpisodeRef) -> dict[str, tuple[tuple[int, ...], str]]:
    """Each array of one episode with its shape and dtype (``images/top``: ``(T, H, W, 3)``,
    ``uint8``), read without loading them."""
    arrays: dict[str, tuple[tuple[int, ...], str]] = {}
    with open_h5(ref.file) as f:
        group = f[ref.group]

        def visit(name: str, node: object) -> None:
            if isinstance(node, h5py.Dataset):
                arrays[name] = (tuple(node.shape), str(node.dtype))

        group.visititems(visit)
    return arrays
