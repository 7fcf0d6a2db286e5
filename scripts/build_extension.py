# SPDX-License-Identifier: GPL-3.0-or-later
"""Build the installable Blender extension zips, one per platform, into ``dist/``.

Blender extensions bundle their Python dependencies as wheels listed in
``blender_manifest.toml``. This script fetches exactly those wheels (cp311, because Blender
4.2+ runs Python 3.11) with ``pip download`` into ``wheels/`` (git-ignored, never committed),
then builds the zips with Blender's own extension tool (``blender_ext.py build
--split-platforms``, shipped with the ``bpy`` module: each zip carries only its platform's
wheels), so the manifest's ``[build] paths_exclude_pattern`` is applied by the same code
Blender uses, and finally checks each zip's contents.

Usage: ``python scripts/build_extension.py [--offline] [--output-dir DIR]``.
"""
from __future__ import annotations

import argparse
import importlib.util
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
MANIFEST = REPO_ROOT / "blender_manifest.toml"
REQUIREMENTS = REPO_ROOT / "requirements.txt"
WHEEL_DIR = REPO_ROOT / "wheels"
DIST_DIR = REPO_ROOT / "dist"

# Blender 4.2 .. 5.x embed CPython 3.11.
BLENDER_PYTHON_VERSION = "3.11"
# Packages bundled as wheels; their versions are pinned once, in requirements.txt.
BUNDLED_PACKAGES = ("moderngl", "glcontext")
# pip platform tag for each Blender platform the manifest may declare.
PIP_PLATFORM_TAGS = {
    "linux-x64": "manylinux2014_x86_64",
    "windows-x64": "win_amd64",
    "macos-arm64": "macosx_11_0_arm64",
}

# What the zip must hold, and what must never be in it.
REQUIRED_ENTRIES = (
    "__init__.py",
    "blender_manifest.toml",
    "hybrid_engine/",
    "gpu_shaders/",
    "blender_adapter/",
    "operators/",
    "ui/",
    "wheels/",
)
FORBIDDEN_PREFIXES = (
    "tests/", ".ci/", ".venv/", ".git/", "docs/", "scripts/", "farm/", "out/", "dist/", "Makefile",
)
FORBIDDEN_PARTS = ("__pycache__",)


class BuildError(RuntimeError):
    """The extension could not be built; the message says which step failed and why."""


def read_manifest() -> dict:
    with MANIFEST.open("rb") as fh:
        return tomllib.load(fh)


def pinned_versions() -> dict[str, str]:
    """Versions of the bundled packages, from requirements.txt (the one place they are pinned)."""
    pins: dict[str, str] = {}
    for line in REQUIREMENTS.read_text(encoding="utf-8").splitlines():
        match = re.match(r"^\s*([A-Za-z0-9_.-]+)\s*==\s*([^\s;#]+)", line)
        if match and match.group(1).lower() in BUNDLED_PACKAGES:
            pins[match.group(1).lower()] = match.group(2)
    missing = [name for name in BUNDLED_PACKAGES if name not in pins]
    if missing:
        raise BuildError(f"{REQUIREMENTS.name} does not pin {', '.join(missing)} with '=='")
    return pins


def manifest_wheels(manifest: dict) -> list[Path]:
    """The wheel files the manifest lists, checked against the pinned versions."""
    pins = pinned_versions()
    wheels = [REPO_ROOT / rel for rel in manifest.get("wheels", [])]
    found = set()
    for wheel in wheels:
        name, version = wheel.name.split("-")[:2]
        name = name.lower().replace("_", "-")
        if name not in pins:
            raise BuildError(f"manifest lists a wheel of an unbundled package: {wheel.name}")
        if version != pins[name]:
            raise BuildError(
                f"manifest wheel {wheel.name} has version {version}, "
                f"requirements.txt pins {name}=={pins[name]}: update the manifest"
            )
        found.add(name)
    absent = [name for name in BUNDLED_PACKAGES if name not in found]
    if absent:
        raise BuildError(f"manifest 'wheels' lacks {', '.join(absent)}")
    return wheels


def download_wheels(manifest: dict, offline: bool) -> list[Path]:
    """Make sure every wheel the manifest lists is in wheels/, downloading what is missing."""
    wheels = manifest_wheels(manifest)
    missing = [w for w in wheels if not w.is_file()]
    if not missing:
        return wheels
    if offline:
        raise BuildError(
            "wheels missing and --offline given: " + ", ".join(w.name for w in missing)
        )
    pins = pinned_versions()
    WHEEL_DIR.mkdir(exist_ok=True)
    for platform in manifest.get("platforms", ["linux-x64"]):
        tag = PIP_PLATFORM_TAGS.get(platform)
        if tag is None:
            raise BuildError(f"no pip platform tag known for manifest platform {platform!r}")
        cmd = [
            sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
            "--only-binary=:all:", "--python-version", BLENDER_PYTHON_VERSION,
            "--implementation", "cp", "--platform", tag, "--dest", str(WHEEL_DIR),
            *(f"{name}=={pins[name]}" for name in BUNDLED_PACKAGES),
        ]
        print("fetching wheels for", platform, flush=True)
        result = subprocess.run(cmd, capture_output=True, text=True)
        if result.returncode != 0:
            raise BuildError(f"pip download failed for {platform}:\n{result.stderr.strip()}")
    still_missing = [w for w in wheels if not w.is_file()]
    if still_missing:
        have = sorted(p.name for p in WHEEL_DIR.glob("*.whl"))
        raise BuildError(
            "pip downloaded wheels whose names differ from the manifest's 'wheels' list; "
            f"missing {[w.name for w in still_missing]}, downloaded {have}"
        )
    return wheels


def blender_ext_tool() -> tuple[Path, Path]:
    """Blender's extension command-line tool and its list of valid tags, from the bpy module.

    Located with find_spec so that bpy itself is not imported (that costs seconds).
    """
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise BuildError("the 'bpy' module is not installed; run 'make package' (it installs it)")
    bpy_dir = Path(next(iter(spec.submodule_search_locations)))
    tools = sorted(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    tags = sorted(bpy_dir.glob("*/scripts/modules/_bpy_internal/extensions/tags.py"))
    if not tools or not tags:
        raise BuildError(f"Blender's extension tool (blender_ext.py) not found under {bpy_dir}")
    return tools[-1], tags[-1]


def check_zip(path: Path) -> list[str]:
    """The zip's entry names, after checking that nothing required is missing or extra."""
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
    problems = []
    for required in REQUIRED_ENTRIES:
        if not any(n == required or n.startswith(required) for n in names):
            problems.append(f"missing {required}")
    for name in names:
        if name.startswith(FORBIDDEN_PREFIXES) or any(p in name.split("/") for p in FORBIDDEN_PARTS):
            problems.append(f"must not contain {name}")
    if problems:
        raise BuildError(f"{path.name}: " + "; ".join(problems))
    return names


def platform_zip(output_dir: Path, manifest: dict, platform: str) -> Path:
    """Where ``blender_ext.py build --split-platforms`` writes ``platform``'s zip."""
    return output_dir / f"{manifest['id']}-{manifest['version']}-{platform.replace('-', '_')}.zip"


def build(output_dir: Path = DIST_DIR, offline: bool = False) -> dict[str, Path]:
    """Fetch wheels, build one zip per manifest platform with Blender's tool, check each;
    returns {platform: zip path}."""
    manifest = read_manifest()
    download_wheels(manifest, offline)
    tool, tags = blender_ext_tool()
    output_dir.mkdir(parents=True, exist_ok=True)
    for step in (["validate", str(REPO_ROOT)],
                 ["build", "--source-dir", str(REPO_ROOT), "--output-dir", str(output_dir), "--split-platforms"]):
        result = subprocess.run(
            [sys.executable, str(tool), *step, f"--valid-tags={tags}"],
            capture_output=True, text=True,
        )
        if result.returncode != 0:
            raise BuildError(
                f"blender_ext.py {step[0]} failed:\n{(result.stdout + result.stderr).strip()}"
            )
    zips = {platform: platform_zip(output_dir, manifest, platform) for platform in manifest["platforms"]}
    try:
        for platform, path in zips.items():
            if not path.is_file():
                raise BuildError(f"Blender's tool wrote no zip for {platform} ({path.name})")
            check_zip(path)
    except BuildError:
        for path in zips.values():  # never leave a package behind that would install a broken add-on
            path.unlink(missing_ok=True)
        raise
    return zips


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--offline", action="store_true", help="never download wheels")
    parser.add_argument("--output-dir", type=Path, default=DIST_DIR)
    args = parser.parse_args(argv)
    try:
        zips = build(args.output_dir, offline=args.offline)
    except BuildError as exc:
        print(f"build_extension: {exc}", file=sys.stderr)
        return 1
    for out in zips.values():
        print(f"built {out.relative_to(REPO_ROOT) if out.is_relative_to(REPO_ROOT) else out} "
              f"({out.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
