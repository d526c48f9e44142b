"""The code an episode records as its maker: a hash of the package's files, read back for comparison."""

from __future__ import annotations

from pathlib import Path

from pipette_cli.demos.provenance import code_sha256, code_version, describe_code, files_sha256, provenance_code


def test_the_files_hash_follows_content_and_names_and_ignores_bytecode(tmp_path: Path) -> None:
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "pkg" / "sub" / "b.yaml").write_text("k: v\n")
    first = files_sha256(tmp_path / "pkg")
    (tmp_path / "pkg" / "__pycache__").mkdir()
    (tmp_path / "pkg" / "__pycache__" / "a.cpython-312.pyc").write_bytes(b"\0\1")
    assert files_sha256(tmp_path / "pkg") == first  # caches are not code
    (tmp_path / "pkg" / "a.py").write_text("x = 2\n")
    assert files_sha256(tmp_path / "pkg") != first
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    assert files_sha256(tmp_path / "pkg") == first
    (tmp_path / "pkg" / "a.py").rename(tmp_path / "pkg" / "c.py")
    assert files_sha256(tmp_path / "pkg") != first  # a moved file is other code too


def test_an_episode_names_its_code_by_source_and_an_older_one_by_its_commit() -> None:
    here = provenance_code()
    assert here["code_sha256"] == code_sha256() and len(here["code_sha256"]) == 64
    version = code_version(here)
    assert version == code_version({**here, "git_commit": "another"})  # the same files under another commit
    assert version != code_version({**here, "code_sha256": "0" * 64})
    older = code_version({"package_version": "0.1.0", "git_commit": "0f8ee7c01083f2", "mujoco_version": "4.0.0"})
    assert describe_code(older) == "pipette 0.1.0 (commit 0f8ee7c01083) with MuJoCo 4.0.0"
    assert describe_code(version).startswith(f"pipette {here['package_version']} (source {code_sha256()[:12]})")
