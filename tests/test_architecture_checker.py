# The checker of tests/test_architecture.py on small synthetic crates: the cycles it must find
# (plain, through re-exports, through use-bound module names, in files no `mod` reaches yet,
# behind #[path]) and the ones it must not (comments, strings, re-exports of children).
"""Tests of the architecture checker itself (see tests/test_architecture.py)."""

from __future__ import annotations

import pathlib

from test_architecture import CrateModel, code_lines, find_cycles

def _crate(tmp: pathlib.Path, files: dict[str, str]) -> pathlib.Path:
    (tmp / "crates" / "demo").mkdir(parents=True)
    (tmp / "crates" / "demo" / "Cargo.toml").write_text('[package]\nname = "demo"\n')
    for rel, text in files.items():
        p = tmp / "crates" / "demo" / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp


LIB = "//! demo\npub mod a;\npub mod b;\npub mod sub;\npub use a::A;\npub use sub::inner::{self, Deep as D};\n"
SUB = "pub mod inner;\npub use self::inner::Deep;\n"


def test_synthetic_crate_without_cycle_is_clean(tmp_path):
    repo = _crate(tmp_path, {
        "src/lib.rs": LIB + "pub fn f() -> a::A { a::A }\n",
        "src/a.rs": '//! uses crate::b in a comment\npub struct A;\nconst S: &str = "crate::b::B";\n'
                    "#[cfg(test)]\nmod tests {\n    use super::*;\n    use crate::sub::inner::Deep;\n}\n",
        "src/b.rs": "use crate::A;\nuse super::sub::Deep;\npub struct B(A, Deep);\n/* crate::b::x /* nested */ crate::a */\n",
        "src/sub/mod.rs": SUB,
        "src/sub/inner.rs": "pub struct Deep;\nfn g<'a>(c: char) -> bool { c == '\"' || c == '{' }\n",
        "tests/t.rs": "mod common;\nuse common::helper;\n",
        "tests/common/mod.rs": "pub fn helper() {}\n",
    })
    assert find_cycles(repo) == []
    model = CrateModel(repo / "crates/demo/src/lib.rs", repo / "crates/demo/src", repo)
    e = {(a.name, b.name) for a, ws in model.edges().items() for b in ws}
    # b -> crate::A resolves through lib.rs's re-export to a.rs; lib -> a because of code, not `pub use`
    # b -> super::sub::Deep resolves through sub/mod.rs's `pub use self::inner::Deep` to inner.rs
    assert e == {("lib.rs", "a.rs"), ("a.rs", "inner.rs"), ("b.rs", "a.rs"), ("b.rs", "inner.rs")}, e


def test_synthetic_cycles_are_detected(tmp_path):
    repo = _crate(tmp_path, {
        "src/lib.rs": LIB + "pub mod c;\n",
        "src/a.rs": "pub struct A;\nfn f() -> crate::b::B { todo!() }\n",
        "src/b.rs": "use super::a::A;\npub struct B(A);\n",
        "src/c.rs": "pub fn z() -> crate::D { crate::D }\n",  # D is sub::inner::Deep, re-exported
        "src/sub/mod.rs": SUB + "fn h() -> inner::Deep { inner::Deep }\n",  # bare child path: mod -> inner
        "src/sub/inner.rs": "use super::*;\npub struct Deep;\npub fn k() { crate::c::z(); }\n",
    })
    cycles = find_cycles(repo)
    by_files = {c.files: c.report for c in cycles}
    ab = frozenset({"crates/demo/src/a.rs", "crates/demo/src/b.rs"})
    deep = frozenset({"crates/demo/src/c.rs", "crates/demo/src/sub/mod.rs", "crates/demo/src/sub/inner.rs"})
    assert set(by_files) == {ab, deep}, [c.report for c in cycles]
    assert "crates/demo/src/a.rs -> crates/demo/src/b.rs -> crates/demo/src/a.rs" in by_files[ab]
    assert "crates/demo/src/a.rs:2 `crate::b::B`" in by_files[ab]
    assert "crates/demo/src/sub/inner.rs:1 `use super::*`" in by_files[deep]


def test_cycle_through_a_use_bound_module_name_is_detected(tmp_path):
    # `use crate::tasks;` then `tasks::multi::...`: the registry <-> multi cycle this rule once missed
    repo = _crate(tmp_path, {
        "src/lib.rs": "pub mod registry;\npub mod tasks;\n",
        "src/registry.rs": "use crate::tasks;\npub fn make() { tasks::multi::build() }\npub fn names() {}\n",
        "src/tasks/mod.rs": "pub mod multi;\n",
        "src/tasks/multi.rs": "use crate::registry;\npub fn build() { registry::names() }\n",
    })
    reg, multi = "crates/demo/src/registry.rs", "crates/demo/src/tasks/multi.rs"
    assert [c.files for c in find_cycles(repo)] == [frozenset({reg, multi})]
    # a `use` path that starts with such a name (`use tasks::multi;`) is followed as well
    repo2 = tmp_path / "second"
    repo2.mkdir()
    _crate(repo2, {
        "src/lib.rs": "pub mod registry;\npub mod tasks;\n",
        "src/registry.rs": "use crate::tasks;\nuse tasks::multi;\npub fn make() { multi::build() }\n",
        "src/tasks/mod.rs": "pub mod multi;\n",
        "src/tasks/multi.rs": "pub fn build() { crate::registry::make() }\n",
    })
    assert [c.files for c in find_cycles(repo2)] == [frozenset({reg, multi})]


def test_unreached_file_of_a_crate_being_restructured_is_checked(tmp_path):
    repo = _crate(tmp_path, {"src/lib.rs": "pub mod x;\n", "src/x.rs": "use crate::y::Y;\npub struct X;\n",
                             "src/y.rs": "pub struct Y(crate::x::X);\n"})
    assert [c.files for c in find_cycles(repo)] == [frozenset({"crates/demo/src/x.rs", "crates/demo/src/y.rs"})]


def test_path_attribute_is_followed(tmp_path):
    repo = _crate(tmp_path, {"src/lib.rs": '#[path = "imp/p.rs"]\nmod p;\nmod q;\n', "src/q.rs": "pub struct Q(crate::p::P);\n",
                             "src/imp/p.rs": "use crate::q::Q;\npub struct P;\n"})
    assert [c.files for c in find_cycles(repo)] == [frozenset({"crates/demo/src/imp/p.rs", "crates/demo/src/q.rs"})]
    model = CrateModel(repo / "crates/demo/src/lib.rs", None, repo)
    assert model.mod_of[repo / "crates/demo/src/imp/p.rs"] == ("p",)


def test_code_line_count():
    rs = "//! doc\n\nfn f() {\n    // comment\n    let s = 1; // trailing\n}\n#[cfg(test)]\nmod tests {}\n"
    assert code_lines(rs, ".rs") == 5
    assert code_lines('#!/usr/bin/env python3\n"""doc"""\n\n  # c\nx = 1  # y\n', ".py") == 2


