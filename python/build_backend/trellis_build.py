"""The PEP 517 build backend behind `pip install .` (pyproject.toml): builds the Python package with
CMake and packs `cmake --install <build> --component python` (python/CMakeLists.txt) into a wheel.

Written here with the standard library only because no backend that drives CMake can be installed:
Debian 12 packages neither scikit-build-core nor scikit-build (`apt-cache policy` knows neither
python3-scikit-build-core nor python3-scikit-build; its python3-mesonpy builds Meson projects) and
PyPI is not reachable. With `requires = []` pip's isolated build has nothing to install.

The build tree: $TRELLIS_BUILD_DIR if set (configured there if it is new), else build/release when
it was configured for this interpreter's extension ABI, else build/wheel-<python tag> (configured
here for this interpreter, without tests and benchmarks). Only the targets the wheel carries are
built. Progress goes to stderr (`pip install -v .` shows it).
"""
import base64
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
import tomllib
import zipfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[2]
NAME = "trellis"
TARGETS = ["_trellis", "trellis_cli", "trellis_modules"]


def _say(message):
    print(f"trellis_build: {message}", file=sys.stderr, flush=True)


def _fail(message):
    _say(message)
    sys.exit(1)


def _run(cmd, **kw):
    _say("$ " + " ".join(map(str, cmd)))
    # CMake's and the compiler's output go to stderr too: pip shows it on failure or with -v.
    if subprocess.run(list(map(str, cmd)), stdout=sys.stderr, **kw).returncode != 0:
        _fail(f"{cmd[0]} failed (its output is above)")


# ---- metadata -------------------------------------------------------------------------------

def _version():
    text = (SOURCE / "CMakeLists.txt").read_text()
    m = re.search(r"project\(\s*trellis\s+VERSION\s+([0-9][0-9.]*)", text)
    if not m:
        _fail(f"no `project(trellis VERSION x.y.z)` in {SOURCE / 'CMakeLists.txt'}")
    return m.group(1)


def _project():
    with open(SOURCE / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["project"]


def _tag():
    if sys.implementation.name != "cpython":
        _fail(f"the extension is built for CPython, not {sys.implementation.name}")
    py = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = re.sub(r"[-.]", "_", sysconfig.get_platform())
    return f"{py}-{py}{sys.abiflags}-{platform}"


def _dist_info_name():
    return f"{NAME}-{_version()}.dist-info"


def _metadata_files():
    """dist-info file name -> text, from pyproject.toml's [project] and CMakeLists.txt's version."""
    p = _project()
    lines = ["Metadata-Version: 2.1", f"Name: {p['name']}", f"Version: {_version()}",
             f"Summary: {p['description']}", f"Requires-Python: {p['requires-python']}"]
    lines += [f"Requires-Dist: {d}" for d in p.get("dependencies", [])]
    scripts = "".join(f"{k} = {v}\n" for k, v in p.get("scripts", {}).items())
    return {
        "METADATA": "\n".join(lines) + "\n",
        "WHEEL": f"Wheel-Version: 1.0\nGenerator: trellis_build\nRoot-Is-Purelib: false\n"
                 f"Tag: {_tag()}\n",
        "entry_points.txt": f"[console_scripts]\n{scripts}",
    }


# ---- the build tree -------------------------------------------------------------------------

def _cache(tree):
    entries = {}
    for line in (tree / "CMakeCache.txt").read_text().splitlines():
        m = re.match(r"([A-Za-z_][A-Za-z0-9_.-]*):[A-Z]+=(.*)", line)
        if m:
            entries[m.group(1)] = m.group(2)
    return entries


def _unsuitable(tree):
    """Why a configured tree cannot build this interpreter's wheel, or None."""
    c = _cache(tree)
    home = c.get("CMAKE_HOME_DIRECTORY", "")
    if not home or Path(home).resolve() != SOURCE:
        return f"it was configured for the sources in {home or '?'}, not {SOURCE}"
    if c.get("TRELLIS_BUILD_PYTHON", "ON").upper() in ("OFF", "0", "FALSE", "NO"):
        return "it was configured with TRELLIS_BUILD_PYTHON=OFF"
    if c.get("TRELLIS_SANITIZE", "OFF").upper() in ("ON", "1", "TRUE", "YES"):
        return "it is a sanitizer build (TRELLIS_SANITIZE=ON: no Python package)"
    ours = sysconfig.get_config_var("EXT_SUFFIX")
    theirs = c.get("PYTHON_MODULE_EXTENSION")
    if theirs is not None and theirs != ours:
        return (f"its extension is built for {c.get('_Python_EXECUTABLE', 'another Python')} "
                f"({theirs}), not for {sys.executable} ({ours})")
    return None


def _configure(tree):
    _say(f"configuring {tree} for {_base_interpreter()}")
    generator = ["-G", "Ninja"] if _which("ninja") else []
    _run(["cmake", "-S", SOURCE, "-B", tree, *generator, "-DCMAKE_BUILD_TYPE=Release",
          "-DTRELLIS_BUILD_TESTS=OFF", "-DTRELLIS_BUILD_BENCH=OFF", "-DTRELLIS_BUILD_PYTHON=ON",
          f"-DPython_EXECUTABLE={_base_interpreter()}"])


def _base_interpreter():
    """The interpreter itself rather than a virtual environment's link to it: the tree's cache
    keeps working after the environment is removed (the extension ABI is the same)."""
    return os.path.realpath(getattr(sys, "_base_executable", sys.executable))


def _which(program):
    return any(os.access(os.path.join(d, program), os.X_OK)
               for d in os.environ.get("PATH", "").split(os.pathsep) if d)


def _build_tree():
    chosen = os.environ.get("TRELLIS_BUILD_DIR")
    if chosen:
        tree = (SOURCE / chosen).resolve()  # relative to the checkout; an absolute path stays
        if (tree / "CMakeCache.txt").exists():
            why = _unsuitable(tree)
            if why:
                _fail(f"TRELLIS_BUILD_DIR={chosen} cannot build this wheel: {why}")
        else:
            _configure(tree)
        return tree
    release = SOURCE / "build" / "release"
    if (release / "CMakeCache.txt").exists():
        why = _unsuitable(release)
        if not why:
            _say(f"reusing the build tree {release}")
            return release
        _say(f"not reusing {release}: {why}")
    tree = SOURCE / "build" / f"wheel-{_tag().split('-')[0]}"
    if not (tree / "CMakeCache.txt").exists() or _unsuitable(tree):
        _configure(tree)
    return tree


def _build_and_stage(tree, stage):
    jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(len(os.sched_getaffinity(0)))
    _run(["cmake", "--build", tree, "-j", jobs, "--target", *TARGETS])
    _run(["cmake", "--install", tree, "--component", "python", "--prefix", stage])


# ---- the wheel ------------------------------------------------------------------------------

def _staged_files(stage):
    """(name in the wheel, file on disk) for every staged file. A wheel holds no symbolic links:
    a link is stored as the file it names, under its own name (libtrellis under its SONAME, the
    name the loader asks for), and a file reached through a link is not stored again."""
    files, linked = [], set()
    for path in sorted(stage.rglob("*")):
        if path.is_symlink():
            target = path.resolve()
            if not target.is_relative_to(stage.resolve()):
                _fail(f"staged {path} links outside the package, to {target}")
            linked.add(target)
            files.append((path, target))
        elif path.is_file():
            files.append((path, path))
    return [(p.relative_to(stage).as_posix(), real) for p, real in files
            if p.is_symlink() or p.resolve() not in linked]


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}\n"


def _write_wheel(path, entries):
    """entries: (name, bytes, executable); RECORD is added last, with every entry's hash."""
    record = ""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data, executable in entries:
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o100755 if executable else 0o100644) << 16
            z.writestr(info, data)
            record += _record_line(name, data)
        name = f"{_dist_info_name()}/RECORD"
        z.writestr(zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0)), record + f"{name},,\n")


# ---- PEP 517 hooks --------------------------------------------------------------------------

def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    info = Path(metadata_directory) / _dist_info_name()
    info.mkdir(parents=True, exist_ok=True)
    for name, text in _metadata_files().items():
        (info / name).write_text(text)
    return info.name


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    tree = _build_tree()
    with tempfile.TemporaryDirectory(prefix="trellis_wheel_") as tmp:
        stage = Path(tmp)
        _build_and_stage(tree, stage)
        if not (stage / NAME / "__init__.py").exists():
            _fail(f"`cmake --install {tree} --component python` staged no {NAME}/__init__.py")
        entries = [(name, real.read_bytes(), name.startswith(f"{NAME}/bin/"))
                   for name, real in _staged_files(stage)]
    info = _dist_info_name()
    entries += [(f"{info}/{n}", t.encode(), False) for n, t in _metadata_files().items()]
    wheel = f"{NAME}-{_version()}-{_tag()}.whl"
    _write_wheel(Path(wheel_directory) / wheel, entries)
    _say(f"wrote {Path(wheel_directory) / wheel} ({len(entries)} files)")
    return wheel


def build_sdist(sdist_directory, config_settings=None):
    """The files git tracks, under trellis-<version>/, with PKG-INFO."""
    listed = subprocess.run(["git", "-C", SOURCE, "ls-files", "-z"], capture_output=True)
    if listed.returncode != 0:
        _fail(f"an sdist is made from a git checkout; {SOURCE} is not one "
              f"({listed.stderr.decode().strip()})")
    root = f"{NAME}-{_version()}"
    sdist = f"{root}.tar.gz"
    with tarfile.open(Path(sdist_directory) / sdist, "w:gz", format=tarfile.PAX_FORMAT) as t:
        for name in sorted(n for n in listed.stdout.decode().split("\0") if n):
            if (SOURCE / name).exists():
                t.add(SOURCE / name, f"{root}/{name}", recursive=False)
        pkg_info = _metadata_files()["METADATA"].encode()
        entry = tarfile.TarInfo(f"{root}/PKG-INFO")
        entry.size, entry.mode = len(pkg_info), 0o644
        t.addfile(entry, io.BytesIO(pkg_info))
    _say(f"wrote {Path(sdist_directory) / sdist}")
    return sdist
