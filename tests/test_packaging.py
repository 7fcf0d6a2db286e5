# SPDX-License-Identifier: GPL-3.0-or-later
"""The extension as users get it: built by scripts/build_extension.py, installed by Blender.

The install test drives Blender's own extension machinery (the operators behind Edit >
Preferences > Get Extensions > Install from Disk) in a child process whose Blender user
directories all point into a temporary folder, so the developer's own Blender setup is never
touched and the in-process add-on registrations of other tests cannot interfere. In that
child, moderngl and glcontext may only be imported from where Blender unpacked the
extension's bundled wheels: the render proves the zip carries working dependencies.

This file is also the child's script: ``python tests/test_packaging.py install-cycle ZIP DIR``.
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
ADDON_PACKAGES = ("hybrid_engine", "gpu_shaders", "blender_adapter", "operators", "ui")
BUNDLED_MODULES = ("moderngl", "glcontext")
ENGINE_ID = "HYBRID_RT"
# A tiny frame: the test proves the installed engine renders, not how well.
RENDER_SIZE = (32, 24)
CHILD_TIMEOUT_S = 300
# The lit grey cube against the dark default World differs by about 0.2; any real shading gives
# more than this, a uniformly cleared frame gives 0.
MIN_CUBE_CONTRAST = 0.02


def load_build_script():
    spec = importlib.util.spec_from_file_location(
        "build_extension", REPO_ROOT / "scripts" / "build_extension.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# The platform tag of each manifest platform's wheels.
WHEEL_PLATFORM_TAGS = {"linux-x64": "manylinux", "windows-x64": "win_amd64"}


@pytest.fixture(scope="module")
def package_zips(tmp_path_factory) -> dict[str, Path]:
    """The extension's zips, one per platform, built once for this module (wheels are
    downloaded if absent)."""
    build = load_build_script()
    return build.build(output_dir=tmp_path_factory.mktemp("dist"))


@pytest.fixture(scope="module")
def package_zip(package_zips) -> Path:
    """The Linux zip: the one this machine installs and runs."""
    return package_zips["linux-x64"]


def manifest() -> dict:
    with (REPO_ROOT / "blender_manifest.toml").open("rb") as fh:
        return tomllib.load(fh)


# ---------------------------------------------------------------------------------------------
# The zip's contents.

def test_manifest_declares_the_fixed_names_and_python_311_wheels():
    data = manifest()
    assert data["id"] == "hybrid_rt"
    assert data["type"] == "add-on"
    assert data["license"] == ["SPDX:GPL-3.0-or-later"]
    wheels = [Path(w).name for w in data["wheels"]]
    assert data["platforms"] == list(WHEEL_PLATFORM_TAGS)
    for platform, tag in WHEEL_PLATFORM_TAGS.items():  # each bundled module once per platform
        assert sorted(w.split("-")[0] for w in wheels if tag in w) == sorted(BUNDLED_MODULES), platform
    assert all("-cp311-cp311-" in w for w in wheels), wheels


def expected_zip_entries(data: dict, platform: str = "linux-x64") -> set[str]:
    """Every file ``platform``'s package must hold: the add-on's own files, manifest, licence,
    that platform's wheels; nothing else (GPL-3.0 asks for its text to travel with the program)."""
    expected = {"__init__.py", "blender_manifest.toml", "LICENSE"}
    expected |= {w.removeprefix("./") for w in data["wheels"] if WHEEL_PLATFORM_TAGS[platform] in w}
    for package in ADDON_PACKAGES:
        for path in (REPO_ROOT / package).rglob("*"):
            if path.is_file() and "__pycache__" not in path.parts and path.suffix != ".pyc":
                expected.add(path.relative_to(REPO_ROOT).as_posix())
    return expected


def test_zip_holds_exactly_the_addon_files_and_wheels(package_zip):
    with zipfile.ZipFile(package_zip) as zf:
        names = set(zf.namelist())
    expected = expected_zip_entries(manifest())
    assert sorted(names - expected) == [], "files that must stay out of the package"
    assert sorted(expected - names) == [], "add-on files missing from the package"
    assert not any(n.startswith(("tests/", ".ci/", ".venv/", "scripts/", "docs/", "benchmarks/", "farm/")) for n in names)


def test_zip_holds_no_test_or_benchmark_module(package_zip):
    """The benchmark, the scene builders and the LBVH reference are development tooling: the
    artist's Blender never runs them, so the zip must not carry them under any folder."""
    with zipfile.ZipFile(package_zip) as zf:
        modules = [Path(n) for n in zf.namelist() if n.endswith(".py")]
    tooling = [m.as_posix() for m in modules
               if m.name.startswith("test_") or m.name in ("conftest.py", "bench.py", "lbvh_reference.py",
                                                            "scene_library.py", "chess.py")]
    assert modules and tooling == []


@pytest.mark.parametrize("platform", ["linux-x64", "windows-x64"])
def test_each_platforms_zip_passes_blenders_archive_validation(package_zips, platform):
    build = load_build_script()
    tool, tags = build.blender_ext_tool()
    result = subprocess.run(
        [sys.executable, str(tool), "validate", str(package_zips[platform]), f"--valid-tags={tags}"],
        capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_windows_zip_carries_the_addon_and_only_windows_wheels(package_zips):
    """Blender's installer on Windows takes the windows_x64 zip: the same add-on files, and
    moderngl and glcontext built for win_amd64, no Linux shared library."""
    with zipfile.ZipFile(package_zips["windows-x64"]) as zf:
        names = set(zf.namelist())
    assert names == expected_zip_entries(manifest(), "windows-x64")
    wheels = sorted(n for n in names if n.endswith(".whl"))
    assert [Path(w).name.split("-")[0] for w in wheels] == ["glcontext", "moderngl"]
    assert all(w.endswith("-cp311-cp311-win_amd64.whl") for w in wheels), wheels
    assert not any(n.endswith(".so") or "manylinux" in n for n in names)
    sizes = {platform: path.stat().st_size for platform, path in package_zips.items()}
    print(f"\nzip sizes: {sizes}")


# ---------------------------------------------------------------------------------------------
# Install, enable, render, disable, uninstall, remove the repository: nothing left behind.

def blender_user_env(home: Path) -> dict[str, str]:
    """Environment that points every Blender user directory into ``home``."""
    env = dict(os.environ)
    for var, sub in (
        ("BLENDER_USER_RESOURCES", "resources"),
        ("BLENDER_USER_CONFIG", "config"),
        ("BLENDER_USER_SCRIPTS", "scripts"),
        ("BLENDER_USER_EXTENSIONS", "extensions"),
        ("BLENDER_USER_DATAFILES", "datafiles"),
    ):
        env[var] = str(home / sub)
    env.pop("PYTHONPATH", None)
    return env


@pytest.fixture(scope="module")
def install_cycle(package_zip, tmp_path_factory) -> dict:
    """Run the whole user journey once in a sandboxed child process; return its observations."""
    home = tmp_path_factory.mktemp("blender_home")
    result = subprocess.run(
        [sys.executable, __file__, "install-cycle", str(package_zip), str(home)],
        cwd=home, env=blender_user_env(home), capture_output=True, text=True,
        timeout=CHILD_TIMEOUT_S,
    )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    assert lines, f"child process printed no report (exit {result.returncode}):\n{result.stderr[-4000:]}"
    report = json.loads(lines[-1])
    report["stderr_tail"] = result.stderr[-4000:]
    report["home"] = str(home)
    return report


def test_install_keeps_online_access_off(install_cycle):
    assert install_cycle["online_access"] is False


def test_install_from_disk_into_a_local_repository_enables_the_addon(install_cycle):
    steps = install_cycle["steps"]
    assert steps["repo_add"] == ["FINISHED"], install_cycle["stderr_tail"]
    assert steps["install"] == ["FINISHED"], install_cycle["stderr_tail"]
    installed = install_cycle["installed"]
    assert installed["addon_enabled"], install_cycle
    assert installed["engine_registered"] and installed["engine_selectable"]
    assert installed["scene_settings"] and installed["material_settings"]
    assert set(installed["bundled_in_site_packages"]) == set(BUNDLED_MODULES)


def test_installed_engine_renders_a_frame_with_the_bundled_wheels(install_cycle):
    render = install_cycle["render"]
    assert render.get("error") is None, render.get("error", "") + install_cycle["stderr_tail"]
    assert render.get("written"), "no image was written"
    assert render["size"] == list(RENDER_SIZE)
    assert render["finite"]
    assert render["max_rgb"] > 0.0, "the rendered frame is black"
    assert render["centre_minus_corner"] > MIN_CUBE_CONTRAST, "the cube is not in the frame"
    home = install_cycle["home"]
    for module, origin in render["module_origins"].items():
        assert origin.startswith(home), f"{module} came from {origin}, not the installed wheels"


def test_disable_uninstall_and_repo_removal_leave_nothing_behind(install_cycle):
    after = install_cycle["after_disable"]
    assert not after["addon_enabled"]
    assert not after["engine_registered"] and not after["engine_selectable"]
    assert not after["scene_settings"] and not after["material_settings"]
    steps = install_cycle["steps"]
    assert steps["uninstall"] == ["FINISHED"], install_cycle["stderr_tail"]
    removed = install_cycle["after_uninstall"]
    assert not removed["package_dir_exists"]
    assert removed["bundled_in_site_packages"] == []
    assert steps["repo_remove"] == ["FINISHED"], install_cycle["stderr_tail"]
    gone = install_cycle["after_repo_remove"]
    assert not gone["repo_listed"]
    assert not gone["repo_dir_exists"]


# ---------------------------------------------------------------------------------------------
# In-process: repeated unregister/register leaves no leftovers.

SNAPSHOT_TYPES = ("Scene", "Material", "Object", "World", "Light", "Camera", "Mesh", "ViewLayer",
                  "WindowManager")


def registered_engines() -> list[str]:
    """bl_idname of every RenderEngine class Blender currently has registered.

    (RenderSettings.engine's static enum items list only the built-in engines, and a class
    stays in __subclasses__() after unregistering until it is garbage collected.)
    """
    import bpy

    return sorted(
        cls.bl_idname for cls in bpy.types.RenderEngine.__subclasses__()
        if getattr(cls, "is_registered", False) and hasattr(cls, "bl_idname")
    )


def engine_selectable(scene) -> bool:
    """Whether a scene accepts the engine: what a user's render setting depends on."""
    previous = scene.render.engine
    try:
        scene.render.engine = ENGINE_ID
    except TypeError:
        return False
    scene.render.engine = previous
    return True


def all_subclasses(cls) -> list[type]:
    found, stack = [], [cls]
    while stack:
        for sub in stack.pop().__subclasses__():
            found.append(sub)
            stack.append(sub)
    return found


def blender_snapshot() -> dict:
    """What an add-on can add to a Blender session, in comparable form."""
    import bpy

    snapshot = {
        "types": sorted(dir(bpy.types)),
        "engines": registered_engines(),
        "operators": sorted(dir(bpy.ops.hybrid_rt)),
        # ui/ adds the engine to the COMPAT_ENGINES of some of Blender's own panels.
        "panels_listing_engine": sorted(
            cls.__name__ for cls in all_subclasses(bpy.types.Panel)
            if getattr(cls, "is_registered", False)
            and ENGINE_ID in (getattr(cls, "COMPAT_ENGINES", None) or ())
        ),
        "handlers": {
            name: len(getattr(bpy.app.handlers, name))
            for name in dir(bpy.app.handlers)
            if isinstance(getattr(bpy.app.handlers, name), list)
        },
    }
    for type_name in SNAPSHOT_TYPES:
        rna_type = getattr(bpy.types, type_name)
        snapshot[type_name] = sorted(rna_type.bl_rna.properties.keys())
    return snapshot


def test_repeated_register_unregister_leaves_no_leftovers():
    import bpy

    from conftest import load_addon

    bpy.ops.wm.read_factory_settings(use_empty=True)
    before = blender_snapshot()
    assert ENGINE_ID not in before["engines"], "the engine is registered before the test"
    addon = load_addon()
    for _ in range(3):
        addon.register()
        try:
            registered = blender_snapshot()
            assert ENGINE_ID in registered["engines"]
            assert engine_selectable(bpy.context.scene)
            assert "hybrid_rt" in registered["Scene"] and "hybrid_rt" in registered["Material"]
        finally:
            addon.unregister()
        after = blender_snapshot()
        leftovers = {key: value for key, value in after.items() if value != before[key]}
        assert leftovers == {}, f"left behind after unregister(): {leftovers}"
        assert not engine_selectable(bpy.context.scene)
        assert not hasattr(bpy.types.Scene, "hybrid_rt") and not hasattr(bpy.types.Material, "hybrid_rt")


# ---------------------------------------------------------------------------------------------
# The child process (runs inside a sandboxed Blender, see install_cycle).

def _child_install_cycle(zip_path: str, home: str) -> dict:
    import importlib.abc
    import importlib.machinery

    class BundledOnlyFinder(importlib.abc.MetaPathFinder):
        """moderngl/glcontext only from below ``home``: where Blender puts extension wheels."""

        def find_spec(self, fullname, path, target=None):
            if path is not None or fullname not in BUNDLED_MODULES:
                return None
            search = [p for p in sys.path if p.startswith(home)]
            spec = importlib.machinery.PathFinder.find_spec(fullname, search)
            if spec is None:
                raise ModuleNotFoundError(f"{fullname} is not installed from the extension's wheels",
                                          name=fullname)
            return spec

    sys.meta_path.insert(0, BundledOnlyFinder())

    import bpy

    report: dict = {"steps": {}, "online_access": bool(bpy.app.online_access)}
    prefs = bpy.context.preferences
    repo_dir = Path(home) / "local_repo"
    site_packages = Path(bpy.utils.user_resource("EXTENSIONS")) / ".local" / "lib" / (
        f"python{sys.version_info[0]}.{sys.version_info[1]}") / "site-packages"

    def state(addon_module: str) -> dict:
        return {
            "addon_enabled": addon_module in prefs.addons,
            "engine_registered": ENGINE_ID in registered_engines(),
            "engine_selectable": engine_selectable(bpy.context.scene),
            "scene_settings": hasattr(bpy.types.Scene, "hybrid_rt"),
            "material_settings": hasattr(bpy.types.Material, "hybrid_rt"),
            "bundled_in_site_packages": sorted(
                m for m in BUNDLED_MODULES if (site_packages / m).is_dir()
            ),
        }

    report["steps"]["repo_add"] = sorted(bpy.ops.preferences.extension_repo_add(
        name="hybrid_rt_test", type='LOCAL', use_custom_directory=True,
        custom_directory=str(repo_dir),
    ))
    repo = next(r for r in prefs.extensions.repos if r.name == "hybrid_rt_test")
    repo_module = repo.module
    addon_module = f"bl_ext.{repo_module}.hybrid_rt"

    report["steps"]["install"] = sorted(bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo=repo_module, enable_on_install=True,
    ))
    report["installed"] = state(addon_module)

    # Render the startup scene (cube, light, camera) with the installed engine.
    render: dict = {}
    try:
        scene = bpy.context.scene
        scene.render.engine = ENGINE_ID
        scene.render.resolution_x, scene.render.resolution_y = RENDER_SIZE
        scene.render.resolution_percentage = 100
        scene.render.image_settings.file_format = 'OPEN_EXR'
        scene.render.filepath = str(Path(home) / "frame.exr")
        bpy.ops.render.render(write_still=True)
        render["written"] = Path(scene.render.filepath).is_file()
        if render["written"]:
            import numpy as np

            image = bpy.data.images.load(scene.render.filepath)
            pixels = np.empty(len(image.pixels), dtype=np.float32)
            image.pixels.foreach_get(pixels)
            rgba = pixels.reshape(image.size[1], image.size[0], -1)
            render["size"] = list(image.size)
            render["finite"] = bool(np.isfinite(rgba).all())
            render["max_rgb"] = float(rgba[..., :3].max())
            # The startup camera frames the cube in the middle; the corners see the World.
            height, width = rgba.shape[:2]
            centre = rgba[height // 2, width // 2, :3]
            corner = rgba[0, 0, :3]
            render["centre_minus_corner"] = float(np.abs(centre - corner).max())
            bpy.data.images.remove(image)
    except Exception as exc:  # reported to the parent, which fails with it
        render["error"] = f"{type(exc).__name__}: {exc}"
    render["module_origins"] = {
        m: getattr(sys.modules.get(m), "__file__", None) or "not imported" for m in BUNDLED_MODULES
    }
    report["render"] = render

    bpy.ops.preferences.addon_disable(module=addon_module)
    report["after_disable"] = state(addon_module)

    repo_index = list(prefs.extensions.repos).index(repo)
    report["steps"]["uninstall"] = sorted(bpy.ops.extensions.package_uninstall(
        repo_index=repo_index, pkg_id="hybrid_rt",
    ))
    report["after_uninstall"] = {
        **state(addon_module),
        "package_dir_exists": (repo_dir / "hybrid_rt").exists(),
    }

    report["steps"]["repo_remove"] = sorted(bpy.ops.preferences.extension_repo_remove(
        index=repo_index, remove_files=True,
    ))
    report["after_repo_remove"] = {
        "repo_listed": any(r.name == "hybrid_rt_test" for r in prefs.extensions.repos),
        "repo_dir_exists": repo_dir.exists(),
    }
    return report


if __name__ == "__main__" and len(sys.argv) == 4 and sys.argv[1] == "install-cycle":
    print(json.dumps(_child_install_cycle(sys.argv[2], sys.argv[3])), flush=True)
