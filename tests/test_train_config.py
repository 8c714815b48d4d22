"""dcdc.configs: dataclass <-> dict <-> TOML, --set overrides, one-line errors."""
from dataclasses import dataclass, field

import numpy as np
import pytest

from dcdc.configs import (apply_overrides, coerce, from_dict, load_toml, parse_override,
                          save_toml, to_dict)
from dcdc.errors import DcdcError


@dataclass
class Inner:
    k: int = 3
    w: tuple[float, ...] = (0.5, 0.5)


@dataclass
class Outer:
    name: str = "a"
    rate: float = 1.0
    flag: bool = False
    limit: float | None = None
    inner: Inner = field(default_factory=Inner)
    items: list[Inner] = field(default_factory=list)


def test_round_trip_through_toml(tmp_path):
    o = Outer("b", 2.5, True, 7.0, Inner(4, (1.0,)), [Inner(1), Inner(2)])
    path = save_toml(to_dict(o), tmp_path / "c.toml")
    assert not list(tmp_path.glob(".*tmp*"))  # written atomically, nothing left over
    assert from_dict(Outer, load_toml(path)) == o
    assert "limit" not in to_dict(Outer())  # None is left out (TOML has no null)


def test_coercion_rules():
    assert coerce(3, float, "x") == 3.0 and isinstance(coerce(3, float, "x"), float)
    assert coerce(np.int64(4), int, "x") == 4 and type(coerce(np.int64(4), int, "x")) is int
    assert coerce([1, 2], tuple[int, ...], "x") == (1, 2)
    assert coerce(np.array([1.0, 2.0]), tuple[float, ...], "x") == (1.0, 2.0)
    assert coerce(None, float | None, "x") is None
    for v, tp, msg in [(True, int, "x must be an integer"), (4.0, int, "x must be an integer"),
                       (1, bool, "x must be true or false"), ("1", float, "finite number"),
                       (float("inf"), float, "finite number"), (3, str, "must be a string"),
                       ([1, "a"], tuple[int, ...], r"x\[1\] must be an integer"),
                       (5, list[int], "x must be a list")]:
        with pytest.raises(DcdcError, match=msg):
            coerce(v, tp, "x")


def test_from_dict_names_the_key():
    with pytest.raises(DcdcError, match="unknown setting inner.kk .known in inner: k, w."):
        from_dict(Outer, {"inner": {"kk": 1}})
    with pytest.raises(DcdcError, match=r"items\[1\].k must be an integer"):
        from_dict(Outer, {"items": [{"k": 1}, {"k": "x"}]})
    with pytest.raises(DcdcError, match="inner must be a table"):
        from_dict(Outer, {"inner": 5})


def test_overrides():
    assert parse_override("a.b=1e-4") == (["a", "b"], 1e-4)
    assert parse_override("name=cconv") == (["name"], "cconv")  # a bare word is a string
    assert parse_override('name="x y"') == (["name"], "x y")
    assert parse_override("w=[1, 2]") == (["w"], [1, 2])
    d = apply_overrides({"inner": {"k": 1}}, ["inner.k=5", "rate=2", "new.deep.x=true"])
    assert d == {"inner": {"k": 5}, "rate": 2, "new": {"deep": {"x": True}}}
    assert from_dict(Outer, apply_overrides({}, ["inner.w=[0.1, 0.9]"])).inner.w == (0.1, 0.9)
    for bad in ("novalue", "=3", "a..b=1"):
        with pytest.raises(DcdcError, match="--set wants key=value"):
            parse_override(bad)
    with pytest.raises(DcdcError, match="rate is a value, not a table"):
        apply_overrides({"rate": 1.0}, ["rate.x=1"])


def test_toml_file_errors(tmp_path):
    with pytest.raises(DcdcError, match="no such file"):
        load_toml(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[a]\nx = \n")
    with pytest.raises(DcdcError, match=r"bad.toml: not valid TOML .*line 2"):
        load_toml(bad)
