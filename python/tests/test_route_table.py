"""Python's route functions come from the route table and the schema (job/job.hpp RouteSpec,
route_keywords): every route has its function, its keywords are the flagged settings of the
sections it reads that the route (and the chosen planner or kind) uses — checked here against an
evaluation of the schema's `when` terms of our own — and a keyword or key of a section it does not
read is refused naming the setting's key."""
import inspect
import os

import pytest

import trellis
from trellis import _trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
ENDER = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")

SETTINGS = _trellis.settings()
ROUTES = _trellis.routes()


def alternative(alt, route, choice):
    """True/False when `alt` names only the route or the chosen setting; None when it depends on
    the run (facts, other settings)."""
    for op in ("!=", "="):
        if op in alt:
            key, values = alt.split(op, 1)
            if key == "route":
                here = route
            elif choice and key == choice[0]:
                here = choice[1]
            else:
                return None
            return (here in values.split("|")) != (op == "!=")
    return None


def uses(setting, route, choice):
    for term in filter(None, setting["when_terms"].split("; ")):
        results = [alternative(a, route, choice) for a in term.split(" or ")]
        if any(r is None for r in results):
            continue
        if not any(results):
            return False
    return True


def expected_keywords(spec, value):
    choice = (spec["choice"], value) if value else None
    out = {}
    own_first = sorted(SETTINGS, key=lambda s: s["section"] != spec["name"])
    for s in own_first:
        if (s["flag"] and s["section"] in spec["sections"] and s["key"] != spec["choice"]
                and uses(s, spec["name"], None)):
            out.setdefault(s["flag"].replace("-", "_"), s["key"])
    # A keyword names one key whatever the choice; the choice leaves out those it does not use.
    by_key = {s["key"]: s for s in SETTINGS}
    return {k: v for k, v in out.items() if uses(by_key[v], spec["name"], choice)}


def choices_of(spec):
    return next((s["choices"] for s in SETTINGS if s["key"] == spec["choice"]), [])


def call_args(fn, spec):
    """Arguments that satisfy the function's signature without any file being read before the
    keywords are checked: the choice's first value, placeholder inputs, a real machine profile."""
    args, kwargs = [], {}
    for p in inspect.signature(fn).parameters.values():
        if p.default is not p.empty or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        value = ENDER if p.name == "machine" else "not-read-before-the-keywords"
        if not args and spec["choice"]:
            value = choices_of(spec)[0]
        if p.kind == p.KEYWORD_ONLY:
            kwargs[p.name] = value
        else:
            args.append(value)
    return args, kwargs


def test_the_table_names_every_route_once():
    assert [r["name"] for r in ROUTES] == list(_trellis.route_names())


@pytest.mark.parametrize("spec", ROUTES, ids=[r["name"] for r in ROUTES])
def test_every_route_has_its_function_and_exactly_its_keywords(spec):
    fn = getattr(trellis, spec["name"])
    assert callable(fn) and spec["name"] in trellis.__all__
    values = [None] + choices_of(spec)
    assert len(values) > 1 or not spec["choice"]
    for value in values:
        got = trellis._keywords(spec["name"], value)
        assert got == expected_keywords(spec, value), (spec["name"], value)
        for key in got.values():  # every keyword is a setting of a section the route reads
            assert key.split(".")[0] in spec["sections"]
    # The keywords of any one choice are among those of the route.
    union = trellis._keywords(spec["name"])
    for value in values[1:]:
        assert trellis._keywords(spec["name"], value).items() <= union.items()


@pytest.mark.parametrize("spec", ROUTES, ids=[r["name"] for r in ROUTES])
def test_a_setting_of_another_section_is_refused_naming_its_key(spec):
    fn = getattr(trellis, spec["name"])
    args, kwargs = call_args(fn, spec)
    keywords = trellis._keywords(spec["name"])
    foreign = [s for s in SETTINGS if s["section"] not in spec["sections"]]
    assert foreign
    tried = 0
    for s in foreign:
        name = s["flag"].replace("-", "_") if s["flag"] else None
        if name and name not in keywords and name not in inspect.signature(fn).parameters:
            with pytest.raises(trellis.SettingError) as e:
                fn(*args, **kwargs, **{name: 1})
            assert s["key"] in str(e.value) or any(
                o["key"] in str(e.value) for o in foreign if o["flag"] == s["flag"]), str(e.value)
            assert e.value.element == name
            tried += 1
        with pytest.raises(trellis.SettingError) as e:
            fn(*args, **kwargs, set={s["key"]: 1})
        assert e.value.element == s["key"] and f"[{s['section']}]" in str(e.value)
    assert tried > 0


@pytest.mark.parametrize("spec", ROUTES, ids=[r["name"] for r in ROUTES])
def test_a_route_without_a_function_of_its_own_gets_one_from_its_row(spec):
    # What a new row of the table gets with no Python edit: its choice and input as arguments,
    # its outputs as keywords, its settings as keywords, other sections refused.
    fn = trellis._route_function(spec)
    params = inspect.signature(fn).parameters
    names = list(params)
    if spec["choice"]:
        assert names[0] == spec["choice"].split(".", 1)[1]
    if spec["input"]:
        assert spec["input"] in names
    for out in ["output", "machine", "progress", "set"] + spec["outputs"][1:]:
        assert out in names
    args, kwargs = call_args(fn, spec)
    foreign = next(s for s in SETTINGS if s["section"] not in spec["sections"] and s["flag"]
                   and s["flag"].replace("-", "_") not in trellis._keywords(spec["name"]))
    with pytest.raises(trellis.SettingError) as e:
        fn(*args, **kwargs, **{foreign["flag"].replace("-", "_"): 1})
    assert e.value.element == foreign["flag"].replace("-", "_")


@pytest.mark.parametrize("spec", [r for r in ROUTES if r["choice"]], ids=lambda r: r["name"])
def test_a_keyword_another_choice_uses_is_refused_naming_its_key(spec):
    fn = getattr(trellis, spec["name"])
    args, kwargs = call_args(fn, spec)
    union = trellis._keywords(spec["name"])
    refused = 0
    for value in choices_of(spec):
        args[0] = value
        own = trellis._keywords(spec["name"], value)
        for name, key in union.items():
            if name in own:
                continue
            with pytest.raises(trellis.SettingError) as e:
                fn(*args, **kwargs, **{name: 1})
            assert key in str(e.value) and repr(value) in str(e.value), str(e.value)
            refused += 1
    assert refused > 0
