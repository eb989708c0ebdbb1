#!/usr/bin/env bash
# Build the guide (docs/, mdBook) into target/book with its API references, then check every link:
#   target/book/                the guide (docs/SUMMARY.md lists its pages; a missing one fails)
#   target/book/api/python/     the Python API reference (pdoc, from the docstrings of skillmimic_rs)
#   target/book/api/rust/       the Rust API reference (rustdoc; a broken intra-doc link fails)
# A broken link or anchor in the guide fails the build (scripts/check_links.py). Needs
# `scripts/setup.sh --tests` (mdBook, pdoc) and the package installed in .venv (`pip install .`).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
book=target/book
rm -rf "$book"
.tools/bin/mdbook build docs
# the package and each public module (pdoc alone documents a package's __all__, which names
# functions and classes, not the modules)
modules=$(.venv/bin/python -c 'import pkgutil, skillmimic_rs as m; print(" ".join(
    f"skillmimic_rs.{i.name}" for i in pkgutil.iter_modules(m.__path__) if not i.name.startswith("_")))')
# shellcheck disable=SC2086
.venv/bin/python -m pdoc --docformat markdown --no-show-source -o "$book/api/python" skillmimic_rs $modules
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --workspace
mkdir -p "$book/api/rust"
cp -r target/doc/. "$book/api/rust/"
.venv/bin/python scripts/check_links.py "$book"
echo "docs: the guide is in $book/index.html"
