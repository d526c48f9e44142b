"""Find and fix absolute asset paths in USD files (paper, appendix D.2).

``scan_folder`` reads every ``.usd``/``.usda``/``.usdc`` under a folder as an ``Sdf`` layer
(no composition, so one broken file does not hide the others) and lists its sublayers,
references, payloads and asset-valued attributes, each marked absolute or relative. With
``fix=True`` absolute paths are rewritten relative to the file that holds them:

* ``/abs/dir/pkg.usdz[tex.png]`` becomes ``pkg.usdz[tex.png]`` (or ``../x/pkg.usdz[...]``) when a
  ``pkg.usdz`` is found beside the file, in a sibling folder, or elsewhere under the root;
* any other absolute path becomes relative when its target (or a file of the same name found
  the same way) lies under the scanned folder.

A file that does not parse is reported and never written. Before its first rewrite a file
is copied to ``<name>.bak``; running again finds nothing absolute, so the fix is idempotent.
"""

from __future__ import annotations

import os
import re
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path

from pxr import Ar, Sdf, Tf, UsdUtils

USD_SUFFIXES = (".usd", ".usda", ".usdc")
_WINDOWS_ABS = re.compile(r"^[A-Za-z]:[\\/]")


@dataclass
class Reference:
    kind: str  # sublayer | reference | payload | attribute
    where: str  # prim or attribute path ("/" for sublayers)
    path: str
    absolute: bool
    exists: bool
    fixed_to: str | None = None


@dataclass
class FileReport:
    file: str
    references: list[Reference] = field(default_factory=list)
    error: str | None = None
    rewritten: bool = False
    backup: str | None = None


def is_absolute(asset_path: str) -> bool:
    """Whether an asset path (possibly ``pkg.usdz[inner]``) is absolute on any platform."""
    outer = _outer(asset_path)
    return outer.startswith(("/", "\\\\", "file:")) or bool(_WINDOWS_ABS.match(outer))


def _outer(asset_path: str) -> str:
    if Ar.IsPackageRelativePath(asset_path):
        return Ar.SplitPackageRelativePathOuter(asset_path)[0]
    return asset_path


def _collect(layer) -> list[tuple[str, str, str]]:
    """(kind, where, asset path) for every external reference in ``layer``."""
    found = [("sublayer", "/", p) for p in layer.subLayerPaths]

    def visit(path) -> None:
        spec = layer.GetObjectAtPath(path)
        if isinstance(spec, Sdf.PrimSpec):
            for ref in spec.referenceList.GetAddedOrExplicitItems():
                if ref.assetPath:
                    found.append(("reference", str(path), ref.assetPath))
            for pay in spec.payloadList.GetAddedOrExplicitItems():
                if pay.assetPath:
                    found.append(("payload", str(path), pay.assetPath))
        elif isinstance(spec, Sdf.AttributeSpec):
            values = [spec.default] if spec.HasDefaultValue() else []
            values += [layer.QueryTimeSample(path, t) for t in layer.ListTimeSamplesForPath(path)]
            for value in values:
                items = value if isinstance(value, Sdf.AssetPathArray) else [value]
                for item in items:
                    if isinstance(item, Sdf.AssetPath) and item.path:
                        found.append(("attribute", str(path), item.path))

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return found


def _exists(asset_path: str, base: Path) -> bool:
    outer = _outer(asset_path)
    if outer.startswith("file:"):
        outer = outer[5:]
    target = Path(outer) if is_absolute(outer) else base / outer
    return target.is_file()


def _find_by_name(name: str, file_dir: Path, root: Path) -> Path | None:
    """A file called ``name`` beside the USD file, in a sibling folder, or (uniquely) under root."""
    beside = file_dir / name
    if beside.is_file():
        return beside
    siblings = sorted(p for d in file_dir.parent.iterdir() if d.is_dir() for p in [d / name] if p.is_file())
    if len(siblings) == 1:
        return siblings[0]
    anywhere = sorted(root.rglob(name))
    return anywhere[0] if len(anywhere) == 1 else None


def _relative_fix(asset_path: str, file_dir: Path, root: Path) -> str | None:
    inner = None
    outer = asset_path
    if Ar.IsPackageRelativePath(asset_path):
        outer, inner = Ar.SplitPackageRelativePathOuter(asset_path)
    outer = outer[5:] if outer.startswith("file:") else outer
    target = Path(outer.replace("\\", "/"))
    candidate = target if target.is_file() and _under(target, root) else _find_by_name(target.name, file_dir, root)
    if candidate is None:
        return None
    rel = Path(os.path.relpath(candidate.resolve(), file_dir.resolve())).as_posix()
    rel = rel if rel.startswith("../") else f"./{rel}" if "/" in rel else rel
    return Ar.JoinPackageRelativePath(rel, inner) if inner else rel


def _under(path: Path, root: Path) -> bool:
    try:
        path.resolve().relative_to(root.resolve())
        return True
    except ValueError:
        return False


def scan_file(path: Path, root: Path, *, fix: bool) -> FileReport:
    """Report (and with ``fix`` rewrite) the asset paths of one USD file."""
    report = FileReport(str(path))
    try:
        layer = Sdf.Layer.FindOrOpen(str(path))
    except Tf.ErrorException as exc:
        report.error = "cannot parse: " + " ".join(str(exc).split())[:300]
        return report
    if layer is None:
        report.error = "cannot parse"
        return report
    layer.Reload()
    file_dir = path.parent
    fixes: dict[str, str] = {}
    for kind, where, asset_path in _collect(layer):
        ref = Reference(kind, where, asset_path, is_absolute(asset_path), _exists(asset_path, file_dir))
        if ref.absolute:
            ref.fixed_to = _relative_fix(asset_path, file_dir, root)
            if ref.fixed_to:
                fixes[asset_path] = ref.fixed_to
        report.references.append(ref)
    if fix and fixes:
        backup = path.with_name(path.name + ".bak")
        if not backup.exists():
            shutil.copy2(path, backup)
        report.backup = str(backup)
        UsdUtils.ModifyAssetPaths(layer, lambda p: fixes.get(p, p))
        layer.Save()
        report.rewritten = True
    return report


def scan_folder(root: Path, *, fix: bool = False) -> dict:
    """Scan every USD file under ``root``; return the JSON-ready report."""
    files = sorted(p for p in root.rglob("*") if p.suffix in USD_SUFFIXES and p.is_file())
    reports = [scan_file(p, root, fix=fix) for p in files]
    refs = [r for f in reports for r in f.references]
    summary = {
        "files": len(reports),
        "unparseable": sum(1 for f in reports if f.error),
        "references": len(refs),
        "absolute": sum(r.absolute for r in refs),
        "relative": sum(not r.absolute for r in refs),
        "fixable": sum(bool(r.fixed_to) for r in refs),
        "unresolved_absolute": sum(r.absolute and not r.fixed_to for r in refs),
        "missing": sum(not r.exists and not r.absolute for r in refs),
        "rewritten_files": sum(f.rewritten for f in reports),
    }
    return {"root": str(root), "fix": fix, "summary": summary, "files": [asdict(f) for f in reports]}
