"""Implicit designs built in Python, written as OpenVCAD text (.vcad) — the language the slicer
reads (the FGM paper's Appendix B). Operators: ``a | b`` union, ``a & b`` intersection,
``a - b`` difference; ``.translate()``, ``.rotate()``, ``.scale()``; ``fgrade`` for material
fractions. ``str(field)`` is the .vcad text; ``trellis.slice(field, ...)`` slices it.

    part = (trellis.rectprism(40, 30, 10) | trellis.cylinder(10, 18)) - trellis.cylinder(5, 40)
    graded = trellis.fgrade(["0.5 + x/80", "0.5 - x/80"], ["a", "b"], part)
"""
import math
import numbers
import os

from . import _trellis

_TPMS = ("gyroid", "schwarz_p", "schwarz_d", "diamond", "neovius", "iwp")


# Every argument reaches the .vcad text through _num or _str, never verbatim: a number is written
# from a real number only, a string is one .vcad string literal. The .vcad lexer has no escapes
# (a string ends at the next '"'), so a string holding '"' cannot be written and is refused.
def _num(v, name="argument"):
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(v).__name__} {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {v!r}")
    return repr(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def _str(s, name="argument"):
    if not isinstance(s, str):
        raise TypeError(f"{name} must be a string, got {type(s).__name__} {s!r}")
    bad = next((c for c in s if c == '"' or c == "\0"), None)
    if bad is not None:
        raise ValueError(f"{name} must not contain {bad!r} (a .vcad string cannot hold it): {s!r}")
    return '"' + s + '"'


def _args(*xs, material=None):
    parts = [_num(x) for x in xs]
    if material is not None:
        parts.append(_str(material, "material"))
    return ", ".join(parts)


def _field(f, name="argument"):
    if not isinstance(f, Field):
        raise TypeError(f"{name} must be a trellis.Field (a shape or an operation), "
                        f"got {type(f).__name__} {f!r}")
    return f


class Field:
    """An implicit design (a .vcad statement). Besides slicing it, probe it with the kernel the
    slicer uses (the text compiled once, on first use): ``evaluate(points)``, ``bounds()``,
    ``sample(step)`` and ``mesh(step)``."""

    def __init__(self, text):
        self._text = text
        self._core = None

    @staticmethod
    def from_vcad(text, name="<vcad>"):
        """A field from .vcad text (checked now: errors name the line and column)."""
        f = Field(text.rstrip("\n"))
        f._core = _trellis.compile_vcad(f.vcad(), name)
        return f

    def _compiled(self):
        if self._core is None:
            self._core = _trellis.compile_vcad(self.vcad(), "<field>")
        return self._core

    @property
    def materials(self):
        """Material names in order of first appearance (the columns of ``fractions``)."""
        return list(self._compiled().materials)

    def bounds(self):
        """The solid's box ((xmin, ymin, zmin), (xmax, ymax, zmax)); infinite coordinates where
        the design is unbounded (a TPMS without a root box)."""
        return self._compiled().bounds()

    def evaluate(self, points, progress=None):
        """The field at points (n, 3): ``{'distance': (n,), 'fractions': (n, k), 'materials'}``.
        Distance is negative inside, zero on the surface (a signed distance for primitives, a
        bound for the rest); fractions are the materials' volume fractions (k = 0 when the design
        names none)."""
        out = self._compiled().evaluate(points, progress)
        out["materials"] = self.materials
        return out

    def _box(self, box, pad):
        if box is None:
            lo, hi = self.bounds()
            if not all(math.isfinite(v) for v in lo + hi):
                from .errors import SettingError
                raise SettingError("the design is unbounded (a TPMS without a root box?): give "
                                   "box=((xmin, ymin, zmin), (xmax, ymax, zmax))", element="box")
            return [v - pad for v in lo], [v + pad for v in hi]
        if len(box) != 2:
            raise TypeError("box must be (min, max), each (x, y, z)")
        return box

    def sample(self, step, box=None, *, progress=None, max_memory=None, force=False):
        """The field on a grid of spacing ``step`` (mm) over ``box`` (default: the bounds):
        ``distance`` (nx, ny, nz) and ``fractions`` (nx, ny, nz, k), node (i, j, k) at
        (``x[i]``, ``y[j]``, ``z[k]``), and ``origin``, ``step``, ``materials``. A grid beyond
        ``max_memory`` MB (default: half the memory available) is refused with the estimate unless
        ``force``."""
        lo, hi = self._box(box, 0.0)
        out = self._compiled().sample(lo, hi, float(step), float(max_memory or 0), force, progress)
        out["materials"] = self.materials
        return out

    def mesh(self, step, box=None, *, stl=None, progress=None, max_memory=None, force=False):
        """The surface (f = 0) as a triangle mesh by marching cubes at ``step`` mm (OpenVDB, as
        the PBF route's STL comparison), over ``box`` (default: the bounds plus two steps): a
        ``trellis.Mesh`` with ``vertices`` (n, 3) and ``faces`` (m, 3); ``stl=path`` also writes
        it as binary STL. Refused beyond ``max_memory`` MB unless ``force``."""
        if stl is not None:  # named for STL before the mesh is made
            _trellis.require_output_format(os.fspath(stl), [(".stl", "binary STL")],
                                           "Field.mesh(stl=)", "the mesh", "stl")
        lo, hi = self._box(box, 2 * float(step))
        out = self._compiled().mesh(lo, hi, float(step), float(max_memory or 0), force, progress)
        m = Mesh(out["vertices"], out["faces"])
        if stl is not None:
            m.write_stl(stl)
        return m

    def __or__(self, other):
        return union(self, other)

    def __and__(self, other):
        return intersection(self, other)

    def __sub__(self, other):
        return difference(self, other)

    def translate(self, x, y, z):
        return Field(f"translate({_args(x, y, z)}) {{\n{_indent(self._text)}\n}}")

    def rotate(self, x, y, z):
        """Degrees, about X then Y then Z."""
        return Field(f"rotate({_args(x, y, z)}) {{\n{_indent(self._text)}\n}}")

    def scale(self, x, y=None, z=None):
        a = _args(x) if y is None else _args(x, y, z)
        return Field(f"scale({a}) {{\n{_indent(self._text)}\n}}")

    def vcad(self):
        """The design as .vcad text."""
        return self._text + "\n"

    def __str__(self):
        return self.vcad()

    def __repr__(self):
        first = self._text.splitlines()[0]
        return f"<trellis.Field {first[:60]}>"


class Mesh:
    """A triangle mesh: ``vertices`` (n, 3) float and ``faces`` (m, 3) vertex indices,
    counter-clockwise seen from outside."""

    def __init__(self, vertices, faces):
        self.vertices = vertices
        self.faces = faces

    def volume(self):
        """The enclosed volume (mm³), from the divergence theorem (closed meshes)."""
        v = self.vertices[self.faces]
        return float((v[:, 0] * (_cross(v[:, 1], v[:, 2]))).sum() / 6.0)

    def obj_text(self):
        """The mesh as Wavefront OBJ text, coordinates to full double precision (what a route
        reads when a ``Mesh`` is given where a mesh file is expected)."""
        import io
        import numpy
        out = io.StringIO()
        numpy.savetxt(out, numpy.asarray(self.vertices, dtype=float), fmt="v %.17g %.17g %.17g")
        numpy.savetxt(out, numpy.asarray(self.faces, dtype=numpy.int64) + 1, fmt="f %d %d %d")
        return out.getvalue()

    def write_stl(self, path):
        """Binary STL, written atomically by the library's writer; ``path`` is named .stl (any
        case), else ``trellis.SettingError`` and nothing is written."""
        _trellis.write_stl(self.vertices, self.faces, os.fspath(path))

    def __repr__(self):
        return f"<trellis.Mesh {len(self.vertices)} vertices, {len(self.faces)} faces>"


def _cross(a, b):
    import numpy
    return numpy.cross(a, b)


def _indent(text):
    return "\n".join("  " + line for line in text.splitlines())


def _block(op, fields, blend=None):
    head = f"{op}({_num(blend, 'blend')})" if blend else f"{op}()"
    if not fields:
        raise TypeError(f"{op}() needs at least one field")
    return Field(head + " {\n" + "\n".join(_indent(_field(f, f"{op}() argument")._text)
                                          for f in fields) + "\n}")


def union(*fields, blend=None):
    """Union (smooth with a blend radius in mm)."""
    return _block("union", fields, blend)


def intersection(*fields, blend=None):
    return _block("intersection", fields, blend)


def difference(first, *others, blend=None):
    """The first field minus the others."""
    return _block("difference", (first,) + others, blend)


def sphere(r, material=None):
    return Field(f"sphere({_args(r, material=material)});")


def cube(s, material=None):
    return Field(f"cube({_args(s, material=material)});")


def rectprism(x, y, z, material=None):
    """A box of side lengths x, y, z centred at the origin."""
    return Field(f"rectprism({_args(x, y, z, material=material)});")


def cylinder(r, h, material=None):
    return Field(f"cylinder({_args(r, h, material=material)});")


def cone(r, h, material=None):
    return Field(f"cone({_args(r, h, material=material)});")


def torus(R, r, material=None):
    return Field(f"torus({_args(R, r, material=material)});")


def function(lo, hi, expr, material=None):
    """A user field f(x, y, z) <= 0 inside the box lo..hi (muparser expression)."""
    box = f"({_args(*lo)}), ({_args(*hi)})"
    return Field(f"function({box}, {_str(expr, 'expr')}" +
                 (f", {_str(material, 'material')}" if material else "") + ");")


def tpms(kind, cell, c=None, material=None):
    """A TPMS network solid, or the sheet Φ = φ² − c² with c a number or an expression."""
    if kind not in _TPMS:
        from .errors import SettingError
        raise SettingError(f"unknown TPMS '{kind}' (expected {', '.join(_TPMS)})", element="kind")
    parts = [_num(cell, "cell")]
    if c is not None:
        parts.append(_str(c, "c") if isinstance(c, str) else _num(c, "c"))
    if material is not None:
        parts.append(_str(material, "material"))
    return Field(f"{kind}({', '.join(parts)});")


def gyroid(cell, c=None, material=None):
    return tpms("gyroid", cell, c, material)


def mesh(path, material=None):
    """A closed mesh (STL, OBJ, 3MF) as a distance field."""
    return Field(f"mesh({_str(os.path.abspath(os.fspath(path)), 'path')}" +
                 (f", {_str(material, 'material')}" if material else "") + ");")


def fgrade(fractions, materials, body, mode=None):
    """Material volume fractions (expressions of x, y, z, rho, phi, r, ...) over `body`."""
    if isinstance(fractions, str) or isinstance(materials, str):
        raise TypeError("fgrade: fractions and materials are lists of strings")
    head = "fgrade([" + ", ".join(_str(f, "fractions") for f in fractions) + "], [" + \
        ", ".join(_str(m, "materials") for m in materials) + "]" + \
        (f", {_str(mode, 'mode')}" if mode else "") + ")"
    return Field(head + " {\n" + _indent(_field(body, "fgrade body")._text) + "\n}")
