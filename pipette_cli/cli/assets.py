"""``pipette assets``: list, show, validate, render, generate and repair USD assets."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.progress import Progress
from rich.table import Table

from pipette_cli.assets.library import CATEGORIES, AssetEntry, load_asset_library
from pipette_cli.cli.common import STATE, err_console, out_console, print_json
from pipette_cli.cli.listing import Column, Listing
from pipette_cli.errors import AssetError, plural
from pipette_cli.registry import load_registry
from pipette_cli.resources import data_dir

app = typer.Typer(
    help="Browse and check the USD asset library.\n\nExample: pipette assets list --category instruments",
    no_args_is_help=True,
)


def _entries(targets: list[str] | None) -> list[AssetEntry]:
    """Asset ids, ``.usd*`` files or folders of them -> entries (all built-in assets if none)."""
    library = load_asset_library()
    if not targets:
        return sorted(library.entries.values(), key=lambda e: (e.category, e.asset_id))
    out: list[AssetEntry] = []
    for target in targets:
        path = Path(target)
        if path.is_dir():
            files = sorted(p for p in path.rglob("*") if p.suffix in (".usda", ".usd", ".usdc"))
            out += [AssetEntry(p.stem, p.parent.name if p.parent.name in CATEGORIES else "", p) for p in files]
        elif path.suffix in (".usda", ".usd", ".usdc", ".usdz") or path.exists():
            if not path.is_file():
                raise AssetError(f"asset file {path} does not exist")
            out.append(AssetEntry(path.stem, path.parent.name if path.parent.name in CATEGORIES else "", path))
        else:
            out.append(library.get(target))
    return out


@app.command("list")
def list_assets(
    category: Annotated[str | None, typer.Option("--category", "-c", help="Only this category.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List assets by id and category.

    Example: pipette assets list --json
    """
    if category is not None and category not in CATEGORIES:
        raise AssetError(f"unknown category {category!r}; valid: {', '.join(CATEGORIES)}")
    library = load_asset_library()
    entries = [e for e in library.entries.values() if category is None or e.category == category]
    entries.sort(key=lambda e: (e.category, e.asset_id))
    if as_json:
        print_json([{"id": e.asset_id, "category": e.category, "path": str(e.path)} for e in entries])
        return
    shown = CATEGORIES if category is None else (category,)
    counts = ", ".join(f"{c} {sum(e.category == c for e in entries)}" for c in shown)
    rows = [[e.category, e.asset_id] for e in entries]
    out_console.print(Listing(f"{plural(len(entries), 'asset')} ({counts})", [Column("category"), Column("id")], rows))


@app.command("show")
def show(
    asset_id: Annotated[str, typer.Argument(help="Asset id or path to a .usda file.")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Show an asset's semantics: category, mass, size, sites, joints, description.

    Example: pipette assets show centrifuge_benchtop
    """
    entry = _entries([asset_id])[0]
    info = {"path": str(entry.path), **entry.semantics()}
    info["used_by"] = load_registry(STATE.registry_dirs).using(entry.asset_id)
    if as_json:
        print_json(info)
        return
    table = Table(title=info["id"], show_header=False)
    table.add_column("key")
    table.add_column("value", overflow="fold")  # paths are never cut
    for key, value in info.items():
        table.add_row(key, ", ".join(map(str, value)) if isinstance(value, list) else str(value))
    out_console.print(table)


@app.command("validate")
def validate(
    targets: Annotated[
        list[str] | None, typer.Argument(help="Asset ids, .usda files or folders (default: all).")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable report.")] = False,
    physics: Annotated[bool, typer.Option("--physics/--no-physics", help="Run the settle and joint tests.")] = True,
) -> None:
    """Check assets with UsdValidation, our semantics, a MuJoCo compile and physics tests.

    Reports every problem of every asset, exits 1 if any; never modifies a file.

    Example: pipette assets validate centrifuge_benchtop assets/consumables
    """
    from pipette_cli.assets.validate import validate_asset  # deferred: pxr.Usd (~0.19 s)

    entries = _entries(targets)
    reports = []
    t0 = time.perf_counter()
    with Progress(console=err_console, transient=True) as progress:
        task = progress.add_task("validating", total=len(entries))
        for entry in entries:
            progress.update(task, description=entry.asset_id)
            reports.append(validate_asset(entry.path, entry.category or None, physics=physics))
            progress.advance(task)
    failed = [r for r in reports if not r.ok]
    if as_json:
        print_json(
            {
                "assets": [r.as_dict() for r in reports],
                "failed": len(failed),
                "seconds": round(time.perf_counter() - t0, 2),
            }
        )
    else:
        for r in failed:
            for problem in r.problems:
                out_console.print(f"[red]FAIL[/red] {r.asset_id}: {escape(problem)}")
        err_console.print(
            f"{len(reports) - len(failed)}/{plural(len(reports), 'asset')} valid in {time.perf_counter() - t0:.1f} s"
        )
    if failed:
        raise typer.Exit(1)


@app.command("render")
def render(
    targets: Annotated[list[str] | None, typer.Argument(help="Asset ids or files (default: all).")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG file to write.")] = Path("asset_sheet.png"),
    columns: Annotated[int, typer.Option("--columns", help="Thumbnails per row.")] = 12,
) -> None:
    """Render a labelled contact sheet of assets (needs MUJOCO_GL=egl on a headless machine).

    Example: MUJOCO_GL=egl pipette assets render --out docs/asset_sheet.png
    """
    from pipette_cli.assets.render import contact_sheet  # deferred: PIL (~25 ms)

    entries = _entries(targets)
    with Progress(console=err_console, transient=True) as progress:
        task = progress.add_task("rendering", total=len(entries))

        def step(asset_id: str) -> None:
            progress.update(task, description=asset_id, advance=1)

        contact_sheet(entries, out, columns=columns, progress=step)
    out_console.print(str(out))


@app.command("generate")
def generate(
    asset_ids: Annotated[list[str] | None, typer.Argument(help="Generator ids (default: all).")] = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Asset root to write (default: the built-in assets folder).")
    ] = None,
) -> None:
    """Regenerate .usda files from the parametric generators (overwrites them).

    Example: pipette assets generate beaker_250ml --out /tmp/assets
    """
    from pipette_cli.assets.build import generate_assets  # deferred: pxr.Usd (~0.15 s)

    paths = generate_assets(out or data_dir("assets"), asset_ids or None)
    err_console.print(f"wrote {plural(len(paths), 'asset')}")


@app.command("repair-paths")
def repair_paths(
    folder: Annotated[Path, typer.Argument(help="Folder to scan for .usd/.usda/.usdc files.")],
    report: Annotated[Path, typer.Option("--report", help="JSON report to write.")] = Path("report.json"),
    fix: Annotated[
        bool, typer.Option("--fix", help="Rewrite absolute paths as relative (writes <file>.bak first).")
    ] = False,
) -> None:
    """Report absolute vs relative asset paths (sublayers, references, payloads, asset attributes).

    With --fix, rewrites absolute paths relative to their file, including pkg.usdz[inner]
    package paths found beside it. Exits 1 if a file cannot be parsed (it is never written)
    or, with --fix, an absolute path could not be resolved.

    Example: pipette assets repair-paths scenes/ --report report.json --fix
    """
    from pipette_cli.assets.repair import scan_folder  # deferred: pxr.Usd (~0.15 s)

    if not folder.is_dir():
        raise AssetError(f"{folder} is not a folder")
    result = scan_folder(folder, fix=fix)
    report.write_text(json.dumps(result, indent=2) + "\n")
    s = result["summary"]
    err_console.print(
        f"{plural(s['files'], 'file')}, {plural(s['references'], 'path')}: {s['absolute']} absolute, "
        f"{s['relative']} relative, {s['missing']} missing; {plural(s['rewritten_files'], 'file')} rewritten; "
        f"report {report}"
    )
    for f in result["files"]:
        if f["error"]:
            err_console.print(f"[red]error:[/red] {escape(str(f['file']))}: {escape(str(f['error']))} (not modified)")
    if s["unparseable"] or (fix and s["unresolved_absolute"]):
        raise typer.Exit(1)
