"""The compile cache (skelarm_sym/build.py) and the atomic writes (skelarm_sym/files.py): damaged,
foreign or planted libraries are rebuilt, never loaded; the cache is private; files are flushed
before they are renamed; leftovers of killed runs are removed."""

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import skelarm_sym.build as build
import skelarm_sym.files as files
from skelarm_sym import InputError, reference
from skelarm_sym.generate import generate

needs_cc = pytest.mark.skipif(not any(shutil.which(c) for c in ("cc", "gcc", "clang")), reason="no C compiler on PATH")
DEAD_PID = 2**22 + 12345  # above the default pid_max of 4194304: never a running process


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("SKELARM_SYM_CACHE", str(folder))
    return folder


def _sources(n, functions="position", **options):
    """A library for the cache to hold, and its C sources. The tests are about the cache, not the functions:
    one function (``position``, the one test_library_of_another_arm_under_the_key_is_not_loaded calls)
    unless a test calls another."""
    g = generate(n, out=None, langs="c", functions=functions, **options)
    return g, {k: v for k, v in g.sources.items() if k.endswith((".c", ".h"))}


@needs_cc
def test_cache_is_created_private_and_records_a_hash(cache):
    _, sources = _sources(2)
    lib = build.compile_shared(sources)
    assert (cache.stat().st_mode & 0o777) == 0o700 and (lib.parent.stat().st_mode & 0o777) == 0o700
    key, digest = lib.with_name(lib.name + ".sha256").read_text().split()
    assert digest == build.file_sha256(lib) and key.startswith(lib.parent.name)
    assert build.compile_shared(sources) == lib  # reused


@needs_cc
def test_truncated_library_is_rebuilt_not_loaded(cache, rng):
    g, sources = _sources(3, functions="jacobian")
    lib = build.compile_shared(sources)
    good = build.file_sha256(lib)
    with open(lib, "r+b") as handle:  # what a power cut after an un-synced rename leaves
        handle.truncate(lib.stat().st_size // 3)
    # in a child interpreter, so that a regression (loading it) cannot kill the test run
    script = (
        "import numpy as np\n"
        "from skelarm_sym.generate import generate\nfrom skelarm_sym.build import compile_arm\n"
        "arm = compile_arm(generate(3, out=None, langs='c', functions='jacobian'))\n"  # the sources under that key
        "print(repr(arm.jacobian(np.array([0.1, 0.2, 0.3]), np.array([1.0, 0.8, 0.5])).tolist()))\n"
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}, timeout=300)
    assert run.returncode == 0, run.stderr
    expected = reference.kinematics(np.array([0.1, 0.2, 0.3]), lengths=np.array([1.0, 0.8, 0.5])).J
    np.testing.assert_allclose(np.array(eval(run.stdout)), expected, atol=1e-14)
    assert build.file_sha256(lib) == good


@needs_cc
def test_library_of_another_arm_under_the_key_is_not_loaded(cache):
    _, sources2 = _sources(2)
    g3, sources3 = _sources(3)
    lib2, lib3 = build.compile_shared(sources2), build.compile_shared(sources3)
    good3 = build.file_sha256(lib3)
    for with_sidecar in (False, True):  # the library alone, then with its own (valid) sidecar
        shutil.copyfile(lib2, lib3)
        if with_sidecar:
            shutil.copyfile(lib2.with_name(lib2.name + ".sha256"), lib3.with_name(lib3.name + ".sha256"))
        assert build.compile_shared(sources3) == lib3
        assert build.file_sha256(lib3) == good3
    arm = build.compile_arm(g3)
    q, l = np.array([0.3, -0.2, 0.9]), np.array([1.0, 0.8, 0.5])
    np.testing.assert_allclose(arm.position(q, l), reference.kinematics(q, lengths=l).p, atol=1e-14)


@needs_cc
def test_library_is_flushed_before_it_is_renamed(cache, monkeypatch):
    events = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(build.os, "fsync", lambda fd: (events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}") if os.path.exists(f"/proc/self/fd/{fd}") else fd)), real_fsync(fd))[1])
    monkeypatch.setattr(build.os, "replace", lambda a, b: (events.append(("replace", str(a))), real_replace(a, b))[1])
    _, sources = _sources(1)
    build.compile_shared(sources)
    replaced = [path for kind, path in events if kind == "replace"]
    assert len(replaced) == 2
    for path in replaced:
        index = events.index(("replace", path))
        assert ("fsync", path) in events[:index], events


def test_shared_or_foreign_cache_folders_are_refused(tmp_path, monkeypatch):
    _, sources = _sources(1)
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv("SKELARM_SYM_CACHE", str(shared))
    with pytest.raises(InputError, match="writable by group or others"):
        build.compile_shared(sources)
    assert list(shared.iterdir()) == []
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("SKELARM_SYM_CACHE", str(blocker / "cache"))
    with pytest.raises(InputError, match="cannot create the compile cache folder") as info:
        build.compile_shared(sources)
    assert "\n" not in str(info.value)
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # only root can make a folder of another user
        foreign = tmp_path / "foreign"
        foreign.mkdir(mode=0o700)
        os.chown(foreign, 65534, 65534)
        monkeypatch.setenv("SKELARM_SYM_CACHE", str(foreign))
        with pytest.raises(InputError, match="belongs to another user"):
            build.compile_shared(sources)


@needs_cc
def test_build_folders_of_killed_compiles_are_removed(cache):
    _, sources = _sources(1)
    lib = build.compile_shared(sources)
    dead = lib.parent / f".build-{DEAD_PID}-abc"
    old = lib.parent / ".build-x-old"
    alive = lib.parent / f".build-{os.getppid()}-busy"  # a running process: maybe compiling now
    for folder in (dead, old, alive):
        folder.mkdir()
        (folder / "partial.so").write_bytes(b"\x7fELF")
    os.utime(old, (time.time() - 2 * build.STALE_BUILD_SECONDS,) * 2)
    _, other = _sources(2)
    build.compile_shared(other)
    assert not dead.exists() and not old.exists() and alive.exists()


@needs_cc
def test_libraries_unused_for_a_month_are_removed_and_a_reused_one_is_kept(cache):
    """The cache only grew (a new user's held 1195 libraries, 234 MB). A compile now removes the libraries no call has
    built or loaded for UNUSED_LIBRARY_DAYS days; reusing one renews it; folders of other shapes are not touched."""
    _, sources = _sources(1)
    kept = build.compile_shared(sources)
    _, stale_sources = _sources(2)
    stale = build.compile_shared(stale_sources)
    month = time.time() - (build.UNUSED_LIBRARY_DAYS + 1) * 86400
    for path in (kept, stale, *cache.glob("*/lib*.sha256")):
        os.utime(path, (month, month))
    other = cache / "templates"  # not a key folder: the template cache's
    other.mkdir()
    (other / "libold.so").write_bytes(b"x")
    os.utime(other / "libold.so", (month, month))
    assert build.compile_shared(sources) == kept  # reused: marked used now (its sidecar; the library as built)
    assert time.time() - max(p.stat().st_mtime for p in kept.parent.glob("lib*")) < 3600
    _, new_sources = _sources(3)
    build.compile_shared(new_sources)  # a build prunes
    assert kept.exists() and not stale.parent.exists() and (other / "libold.so").exists()


def test_missing_or_malformed_compilers_are_named(monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    with pytest.raises(build.CompilerNotFound, match="no-such-cc-4711"):
        build.find_compiler("no-such-cc-4711 -O2")
    monkeypatch.setenv("CC", "no-such-cc-4712")
    with pytest.raises(build.CompilerNotFound, match="no-such-cc-4712"):
        build.find_compiler()
    monkeypatch.setenv("CC", 'gcc "-O2')
    with pytest.raises(InputError, match="not a valid command line") as info:
        build.find_compiler()
    assert "\n" not in str(info.value)
    if shutil.which("gcc"):
        monkeypatch.setenv("CC", "gcc")
        assert build.find_compiler() == "gcc"
        assert build.find_compiler("gcc -m64") == "gcc -m64"


def test_cli_reports_a_missing_compiler_in_one_line(tmp_path):
    env = {**os.environ, "CC": "no-such-cc-4713", "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    run = subprocess.run([sys.executable, "-m", "skelarm_sym", "generate", "--links", "2", "--out", str(tmp_path), "--compile",
                          "--functions", "position"],  # calls nothing: one function to compile
                         capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode != 0 and "no-such-cc-4713" in run.stderr and "Traceback" not in run.stderr


def test_a_compiler_that_writes_no_library_is_named(cache, tmp_path):
    """A probe: ``CC=true`` (exit 0, no output) gave "No such file or directory: .../libur5.so" from the CLI and a bare
    FileNotFoundError from ``compile_arm``; the compile error now says the compiler wrote no library."""
    if not shutil.which("true"):
        pytest.skip("no `true` program")
    _, sources = _sources(2)
    with pytest.raises(build.CompileError, match="the compiler 'true' exited 0 but wrote no library"):
        build.compile_shared(sources, compiler="true")
    env = {**os.environ, "CC": "true", "SKELARM_SYM_CACHE": str(cache), "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    run = subprocess.run([sys.executable, "-m", "skelarm_sym", "generate", "--links", "2", "--out", str(tmp_path / "o"),
                          "--compile", "--functions", "position"], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode != 0 and "exited 0 but wrote no library" in run.stderr.splitlines()[0]
    assert not (tmp_path / "o").exists()


def test_files_are_flushed_then_renamed_as_a_set(tmp_path, monkeypatch):
    events = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(files.os, "fsync", lambda fd: (events.append("fsync"), real_fsync(fd))[1])
    monkeypatch.setattr(files.os, "replace", lambda a, b: (events.append("replace"), real_replace(a, b))[1])
    generate(2, out=tmp_path)
    first = events.index("replace")
    assert events[:first].count("fsync") >= 3 + 1  # arm2.h, arm2.c, arm2.py and the folder
    assert events[first:first + 3] == ["replace"] * 3 and events[-1] == "fsync"  # the folder after the renames


def test_stale_temporaries_of_killed_runs_are_removed(tmp_path):
    tmp_path.mkdir(exist_ok=True)
    dead = tmp_path / f".arm2.c.{DEAD_PID}.skelarm-k3j_x9ab.tmp"
    old = tmp_path / f".arm2.h.{os.getppid()}.skelarm-x8z2ab_9.tmp"  # a live pid, but old: the pid was reused
    recent = tmp_path / f".arm2.py.{os.getppid()}.skelarm-q1w2e3r4.tmp"
    alive = tmp_path / f".arm2.h.{os.getppid()}.skelarm-zzzzzzzz.tmp"  # a running writer
    other = tmp_path / f".other.c.{DEAD_PID}.skelarm-kkkkkkkk.tmp"  # another prefix: not ours to remove
    spare = tmp_path / f".arm2.c.{DEAD_PID}.skelarm-0badc0de.bak"  # a killed run's hard link of a replaced file
    # a user's own backups, which a looser pattern took for ours (two security reviews): kept however old
    mine = [tmp_path / ".arm2.h.orig.bak", tmp_path / f".arm2.h.{DEAD_PID}.mine.bak", tmp_path / ".arm2.c.20240101.my.tmp",
            tmp_path / ".arm2.h.20240101.bak", tmp_path / ".arm2.c.original.tmp", tmp_path / ".arm2.h.backup01.tmp",
            tmp_path / ".arm2.h.1.20240101.bak",
            tmp_path / ".arm2.h.99999999999999999999.skelarm-abcdefgh.tmp"]  # a pid beyond any: os.kill overflowed
    for path in (dead, old, recent, alive, other, spare, *mine):
        path.write_text("partial")
    for path in (old, *mine):
        os.utime(path, (time.time() - 2 * files.STALE_SECONDS,) * 2)
    generate(2, out=tmp_path)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([recent.name, alive.name, other.name, *(p.name for p in mine), "arm2.c", "arm2.h", "arm2.py"])


# -- a refused compile says why on its first line --------------------------------------------------------

@needs_cc
def test_a_failed_compile_names_the_file_and_the_first_error(cache):
    """The CLI prints only the first line of the exception: it was 'compiling ur10.c failed:' and nothing."""
    source = "#include <math.h>\ndouble half_pi(void)\n{\n    return M_PI_2;\n}\n"
    with pytest.raises(build.CompileError) as info:
        build.compile_shared({"ur10.c": source, "ur10.h": "/* header */\n"})
    assert isinstance(info.value, RuntimeError)
    lines = str(info.value).splitlines()
    first = lines[0]
    assert first.startswith("compiling ur10.c failed: ur10.c:4:"), first  # the build folder's path is left out
    assert "error" in first and "M_PI_2" in first and "undeclared" in first, first
    assert lines[1].startswith("command: ") and "-std=c99" in lines[1] and "-Werror" in lines[1] and "ur10.c" in lines[1]
    assert any("M_PI_2" in line for line in lines[2:])
    assert info.value.command[-1] == "-lm" and "M_PI_2" in info.value.output
    assert [p.name for p in cache.glob("*/.build-*")] == []  # the build folder is removed
    assert list(cache.glob("*/libur10.so")) == []


@needs_cc
def test_a_long_compiler_output_is_cut_to_twenty_lines(cache):
    source = "".join(f"int f{i}(void) {{ return undeclared_{i}; }}\n" for i in range(40))
    with pytest.raises(build.CompileError) as info:
        build.compile_shared({"many.c": source})
    lines = str(info.value).splitlines()
    assert lines[0].startswith("compiling many.c failed: many.c:1:") and "undeclared_0" in lines[0]
    assert len(lines) == 2 + build.COMPILER_LINES + 1
    assert re.fullmatch(r"\.\.\. \(\d+ more lines\)", lines[-1]), lines[-1]
    assert "undeclared_39" in info.value.output  # all of it kept on the exception


def test_compile_failure_messages():
    work = "/cache/key/.build-1-x"
    output = (f"{work}/arm.c: In function 'arm_f':\n{work}/arm.c:12:5: error: 'M_PI_2' undeclared\n"
              "\x1b[01;31mnote\x1b[m: each undeclared identifier is reported only once\n")
    error = build.compile_failure("arm.c", ["cc", "-c", f"{work}/arm.c"], 1, output, work)
    assert str(error).splitlines() == [
        "compiling arm.c failed: arm.c:12:5: error: 'M_PI_2' undeclared",
        f"command: cc -c {work}/arm.c",
        "arm.c: In function 'arm_f':",
        "arm.c:12:5: error: 'M_PI_2' undeclared",
        "note: each undeclared identifier is reported only once",
    ]
    linker = "/usr/bin/ld: arm.o: in function `f':\narm.c:(.text+0x5): undefined reference to `g'\ncollect2: error: ld returned 1 exit status\n"
    assert str(build.compile_failure("arm.c", ["cc"], 1, linker)).splitlines()[0] == (
        "compiling arm.c failed: arm.c:(.text+0x5): undefined reference to `g'"
    )
    assert str(build.compile_failure("arm.c", ["cc"], 139, "")).splitlines()[0] == (
        "compiling arm.c failed: the compiler exited with status 139 and printed nothing"
    )
    assert str(build.compile_failure("arm.c", ["cc"], 1, "x" * 1000)).splitlines()[0] == "compiling arm.c failed: " + "x" * 297 + "..."


# -- the key folder is checked before a cached library is used ------------------------------------------------

@needs_cc
def test_a_key_folder_opened_after_the_build_is_refused_before_loading(cache, monkeypatch):
    g, sources = _sources(2)
    lib = build.compile_shared(sources)
    lib.parent.chmod(0o770)  # group-writable after the build: the library could be swapped before dlopen
    loaded = []
    monkeypatch.setattr(build, "CompiledArm", lambda *args, **kwargs: loaded.append(args))
    with pytest.raises(InputError, match="writable by group or others") as info:
        build.compile_shared(sources)
    assert str(lib.parent) in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(InputError, match="writable by group or others"):
        build.compile_arm(g)
    assert loaded == []
    lib.parent.chmod(0o700)
    assert build.compile_shared(sources) == lib  # private again: used as before


# -- the optimisation level of compiles that pass no flags --------------------------------------------------------

def test_the_optimisation_level_comes_from_the_environment(monkeypatch):
    monkeypatch.delenv("SKELARM_SYM_OPT", raising=False)
    assert build.default_flags() == build.DEFAULT_FLAGS == ("-O2",)
    for level, flags in (("0", ("-O0",)), ("-O1", ("-O1",)), ("s", ("-Os",)), ("", ("-O2",))):
        monkeypatch.setenv("SKELARM_SYM_OPT", level)
        assert build.default_flags() == flags
    monkeypatch.setenv("SKELARM_SYM_OPT", "fast; rm -rf")
    with pytest.raises(InputError, match="SKELARM_SYM_OPT"):
        build.default_flags()


@needs_cc
def test_the_level_is_part_of_the_key_and_the_strict_flags_stay(cache, monkeypatch):
    _, sources = _sources(2)
    commands = []
    real_run = build.subprocess.run
    monkeypatch.setattr(build.subprocess, "run", lambda command, **kw: commands.append(command) or real_run(command, **kw))
    monkeypatch.setenv("SKELARM_SYM_OPT", "0")
    fast = build.compile_shared(sources)
    monkeypatch.setenv("SKELARM_SYM_OPT", "2")
    optimised = build.compile_shared(sources)
    assert fast != optimised and build.compile_shared(sources, flags=("-O2",)) == optimised
    assert len(commands) == 2
    for command, level in zip(commands, ("-O0", "-O2")):
        assert level in command and all(flag in command for flag in build.STRICT_FLAGS)
