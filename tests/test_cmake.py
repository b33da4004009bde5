"""A C user's build (issue 12, part 5): CMakeLists.txt, a plain cc line, --functions, no silent overwrites."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import load_robot
from skelarm_sym.cli import main
from skelarm_sym.errors import InputError
from skelarm_sym.generate import generate
from skelarm_sym.reference import kinematics

APP = r"""
#include <stdio.h>
#include "arm3.h"

int main(void)
{
    const double q[3] = {0.3, 1.2, -0.5};
    double p[2];
    arm3_position(q, p);
    printf("%.15f %.15f\n", p[0], p[1]);
    return 0;
}
"""
EXPECTED = kinematics(np.array([0.3, 1.2, -0.5]), lengths=np.array([1.0, 0.8, 0.5])).p


def _printed(text):
    return np.array([float(x) for x in text.split()])


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_add_subdirectory_and_link_the_prefix_target(tmp_path, capsys):
    assert main(["generate", "--links", "3", "--lengths", "1.0,0.8,0.5", "--prefix", "arm3", "--lang", "c",
                 "--out", str(tmp_path / "generated" / "arm3"), "--cmake"]) == 0
    assert "CMakeLists.txt" in capsys.readouterr().out
    lists = (tmp_path / "generated" / "arm3" / "CMakeLists.txt").read_text()
    assert "add_library(arm3 STATIC arm3.c arm3.h)" in lists
    (tmp_path / "app.c").write_text(APP)
    (tmp_path / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.10)\nproject(app C)\nadd_subdirectory(generated/arm3)\n"
        "add_executable(app app.c)\ntarget_link_libraries(app PRIVATE arm3)\n"
    )
    build = tmp_path / "build"
    for command in (["cmake", "-S", str(tmp_path), "-B", str(build)], ["cmake", "--build", str(build)]):
        r = subprocess.run(command, capture_output=True, text=True)
        assert r.returncode == 0, r.stdout + r.stderr
    assert list(build.rglob("libarm3.a")), "the library is static by default"
    run = subprocess.run([str(build / "app")], capture_output=True, text=True, check=True)
    np.testing.assert_allclose(_printed(run.stdout), EXPECTED, atol=1e-14)


def _cmake(*args, cwd=None):
    r = subprocess.run(["cmake", *args], capture_output=True, text=True, cwd=cwd)
    assert r.returncode == 0, r.stdout + r.stderr
    return r


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_a_parent_project_chooses_shared_on_the_first_configure(tmp_path):
    """``set(ARM3_SHARED ON)`` before add_subdirectory built a static library on the first configure and a shared one
    on the second: cmake_minimum_required(VERSION 3.10) left policy CMP0077 unset, so option() cleared the parent's
    variable once (a C++ integrator's report)."""
    generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=tmp_path / "arm3", cmake=True)
    (tmp_path / "app.c").write_text(APP)
    (tmp_path / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.10)\nproject(app C)\nset(ARM3_SHARED ON)\nadd_subdirectory(arm3)\n"
        "add_executable(app app.c)\ntarget_link_libraries(app PRIVATE arm3::arm3)\n")
    # hidden by default in the parent (a common project-wide setting) exported nothing from the shared library
    r = _cmake("-S", str(tmp_path), "-B", str(tmp_path / "build"), "-DCMAKE_C_VISIBILITY_PRESET=hidden")
    assert "CMP0077" not in r.stderr, r.stderr
    _cmake("--build", str(tmp_path / "build"))
    assert list((tmp_path / "build").rglob("libarm3.so*")) and not list((tmp_path / "build").rglob("libarm3.a"))
    run = subprocess.run([str(tmp_path / "build" / "app")], capture_output=True, text=True, check=True)
    np.testing.assert_allclose(_printed(run.stdout), EXPECTED, atol=1e-14)


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_install_and_find_package(tmp_path):
    """The emitted CMakeLists.txt had no install rules: ``cmake --install`` installed nothing, ``find_package(arm3)``
    failed, and a shared library linked into an installed plugin was not found at run time. It installs the library,
    the header and arm3Config.cmake (target arm3::arm3), with libm by name rather than this machine's path."""
    generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=tmp_path / "arm3", cmake=True)
    prefix = tmp_path / "prefix"
    _cmake("-S", str(tmp_path / "arm3"), "-B", str(tmp_path / "lib_build"))
    _cmake("--build", str(tmp_path / "lib_build"))
    _cmake("--install", str(tmp_path / "lib_build"), "--prefix", str(prefix))
    assert list(prefix.rglob("arm3.h")) and list(prefix.rglob("libarm3.a"))
    configs = list(prefix.rglob("arm3Config.cmake"))
    assert configs
    exported = "".join(p.read_text() for p in configs[0].parent.glob("*.cmake"))
    assert "libm" not in exported and str(tmp_path / "arm3") not in exported  # no path of the build machine
    consumer = tmp_path / "consumer"
    consumer.mkdir()
    (consumer / "app.c").write_text(APP)
    (consumer / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.10)\nproject(consumer C)\nfind_package(arm3 REQUIRED)\n"
        "add_executable(app app.c)\ntarget_link_libraries(app PRIVATE arm3::arm3)\n")
    _cmake("-S", str(consumer), "-B", str(consumer / "build"), f"-DCMAKE_PREFIX_PATH={prefix}")
    _cmake("--build", str(consumer / "build"))
    run = subprocess.run([str(consumer / "build" / "app")], capture_output=True, text=True, check=True)
    np.testing.assert_allclose(_printed(run.stdout), EXPECTED, atol=1e-14)


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_find_package_with_a_version(tmp_path):
    """``find_package(arm3 0.4 REQUIRED)`` failed: no arm3ConfigVersion.cmake was installed (a ROS 2 integrator's
    report). The package's version is skelarm-sym's; any patch of the same minor version is accepted, another minor
    version is not (the interface can change between minor versions before 1.0)."""
    from skelarm_sym import __version__

    major, minor = (int(x) for x in __version__.split(".")[:2])
    generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=tmp_path / "arm3", cmake=True)
    prefix = tmp_path / "prefix"
    _cmake("-S", str(tmp_path / "arm3"), "-B", str(tmp_path / "lib_build"))
    _cmake("--build", str(tmp_path / "lib_build"))
    _cmake("--install", str(tmp_path / "lib_build"), "--prefix", str(prefix))
    consumer = tmp_path / "consumer"
    consumer.mkdir()

    def configure(requested):
        (consumer / "CMakeLists.txt").write_text(
            f"cmake_minimum_required(VERSION 3.11)\nproject(consumer C)\nfind_package(arm3 {requested} REQUIRED)\n"
            "message(STATUS \"arm3 version ${arm3_VERSION}\")\n")
        shutil.rmtree(consumer / "build", ignore_errors=True)
        return subprocess.run(["cmake", "-S", str(consumer), "-B", str(consumer / "build"), f"-DCMAKE_PREFIX_PATH={prefix}"],
                              capture_output=True, text=True)

    ok = configure(f"{major}.{minor}")
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert f"arm3 version {major}.{minor}." in ok.stdout
    for other in (f"{major}.{minor + 1}", f"{major + 1}.{minor}"):
        refused = configure(other)
        assert refused.returncode != 0, refused.stdout
        assert re.search(rf'compatible\s+with\s+requested\s+version\s+"{re.escape(other)}"', refused.stderr), refused.stderr


MINGW = shutil.which("x86_64-w64-mingw32-gcc")
WINE = shutil.which("wine64") or shutil.which("wine") or next(
    (w for w in ("/usr/lib/wine/wine64", "/usr/lib/wine/wine") if Path(w).exists()), None)


@pytest.mark.skipif(shutil.which("cmake") is None or MINGW is None,
                    reason="cmake and MinGW-w64 (apt-get install gcc-mingw-w64-x86-64) for a Windows build")
def test_a_windows_dll_builds_links_and_runs(tmp_path):
    """The CMake target builds as a Windows DLL (MinGW-w64, cross-compiled; a parent hiding symbols by default): the
    program links against its import library and, under Wine when installed (apt-get install wine64), prints what the
    reference computes. A robot's whole C compiles strictly for Windows as well. (MinGW's linker exports every
    function of a DLL without dllexport; MSVC, for which the target sets WINDOWS_EXPORT_ALL_SYMBOLS, is not tried.)"""
    generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=tmp_path / "arm3", cmake=True)
    (tmp_path / "app.c").write_text(APP)
    (tmp_path / "toolchain.cmake").write_text(
        "set(CMAKE_SYSTEM_NAME Windows)\nset(CMAKE_C_COMPILER x86_64-w64-mingw32-gcc)\n"
        "set(CMAKE_FIND_ROOT_PATH /usr/x86_64-w64-mingw32)\nset(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)\n"
        "set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)\nset(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)\n")
    (tmp_path / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.11)\nproject(app C)\nset(ARM3_SHARED ON)\nadd_subdirectory(arm3)\n"
        "add_executable(app app.c)\ntarget_link_libraries(app PRIVATE arm3::arm3)\n")
    build = tmp_path / "build"
    _cmake("-S", str(tmp_path), "-B", str(build), f"-DCMAKE_TOOLCHAIN_FILE={tmp_path / 'toolchain.cmake'}",
           "-DCMAKE_C_VISIBILITY_PRESET=hidden")
    _cmake("--build", str(build))
    dll = next(build.rglob("libarm3.dll"))
    assert (build / "app.exe").exists()
    generate(load_robot(Path(__file__).resolve().parent.parent / "examples" / "robots" / "ur5.toml"), langs="c",
             out=tmp_path / "ur5")
    r = subprocess.run([MINGW, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-c", str(tmp_path / "ur5" / "ur5.c"),
                        "-o", str(tmp_path / "ur5.o")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    if WINE is None:
        return
    shutil.copy(dll, build / "libarm3.dll")
    run = subprocess.run([WINE, str(build / "app.exe")], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "WINEDEBUG": "-all"})
    assert run.returncode == 0, run.stderr
    np.testing.assert_allclose(_printed(run.stdout), EXPECTED, atol=1e-14)


def test_plain_cc_line(tmp_path):
    from skelarm_sym.build import find_compiler

    cc = find_compiler()
    generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=tmp_path)
    (tmp_path / "app.c").write_text(APP)
    r = subprocess.run(f"{cc} -std=c99 -O2 -o app app.c arm3.c -lm", shell=True, cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    run = subprocess.run([str(tmp_path / "app")], capture_output=True, text=True, check=True)
    np.testing.assert_allclose(_printed(run.stdout), EXPECTED, atol=1e-14)


def _declared(header):
    return re.findall(r"^(?:void|int)\s+(\w+)\(", header, re.M)


def test_functions_emits_only_the_named_ones():
    g = generate(3, langs="c,python", out=None, functions="kinematics,jacobian")
    assert _declared(g.sources["arm3.h"]) == ["arm3_jacobian", "arm3_jacobian_batch", "arm3_kinematics", "arm3_kinematics_batch"]
    assert 'regenerate with (in this folder): skelarm-sym generate --links 3 --lang c,python --prefix arm3 --precision double --functions jacobian,kinematics' in g.sources["arm3.h"]
    assert "def jacobian(" in g.sources["arm3.py"] and "def position(" not in g.sources["arm3.py"]
    full = generate(3, langs="c", out=None)
    assert len(g.sources["arm3.c"]) < 0.5 * len(full.sources["arm3.c"])


def test_ik_solve_brings_what_it_needs():
    g = generate(2, langs="c,python", out=None, functions=["ik_solve"])
    assert _declared(g.sources["arm2.h"]) == [
        "arm2_position", "arm2_position_batch", "arm2_ik_step", "arm2_ik_step_batch", "arm2_ik_solve", "arm2_ik_solve_batch"]
    assert "def ik_solve(" in g.sources["arm2.py"]


def test_unknown_function_lists_the_valid_ones(capsys, tmp_path):
    assert main(["generate", "--links", "2", "--functions", "jacobian,kin", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("skelarm-sym: error: unknown function 'kin'; choose from position, jacobian, coriolis, velocity, "
                   "acceleration, kinematics, manipulability, inverse_velocity, ik_step, ik_solve")
    assert not (tmp_path / "o").exists()


def test_other_options_do_not_overwrite_silently(tmp_path, capsys):
    generate(3, prefix="arm3", out=tmp_path)
    before = (tmp_path / "arm3.c").read_text()
    with pytest.raises(InputError, match=r"arm3\.\w+ was generated with other options \(skelarm-sym generate --links 3 "):
        generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", out=tmp_path)
    assert (tmp_path / "arm3.c").read_text() == before  # nothing replaced
    assert main(["generate", "--links", "3", "--precision", "float", "--prefix", "arm3", "--out", str(tmp_path)]) == 2
    assert "--force" in capsys.readouterr().err
    generate(3, prefix="arm3", out=tmp_path)  # the same options: fine
    assert main(["generate", "--links", "3", "--precision", "float", "--prefix", "arm3", "--out", str(tmp_path), "--force"]) == 0
    assert "float" in (tmp_path / "arm3.c").read_text().split("Precision: ", 1)[1][:5]


def test_files_not_made_by_skelarm_sym_are_not_replaced(tmp_path):
    (tmp_path / "arm2.c").write_text("int main(void) { return 0; }\n")
    with pytest.raises(InputError, match="was not generated by skelarm-sym"):
        generate(2, out=tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm2.c"]
    generate(2, out=tmp_path, force=True)
    assert "arm2_jacobian" in (tmp_path / "arm2.c").read_text()
