"""Check every link of a built documentation site (scripts/docs.sh): each relative `href`/`src` of
the guide's pages must name a file of the site, and each `#anchor` an element id (or `<a name>`)
of the page it points to — links into the API references included. Links with a scheme (https:,
mailto:) are not fetched: the site must stand on its own offline. The generated API references'
own pages (`api/`) are their generators' business: rustdoc's `-D warnings` fails on a broken
intra-doc link, and pdoc links inherited members to pages of other packages.

Usage: python scripts/check_links.py SITE_DIR   (exit 1 and one line per broken link)

Written here rather than taken from a package because the candidates either fetch the web
(linkchecker) or need a Rust HTTP stack and a second mdBook back end (mdbook-linkcheck); this is
an offline walk of a few hundred local files with the standard library's HTML parser.
"""

from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

SKIP_DIRS = ("api/",)


class _Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("id",) + (("name",) if tag == "a" else ()):
            if a.get(key):
                self.ids.add(a[key])
        for key in ("href", "src"):
            if a.get(key) is not None and not (tag == "link" and a.get("rel") == "preconnect"):
                self.links.append(a[key])


def parse(path: Path, cache: dict[Path, _Page]) -> _Page:
    if path not in cache:
        page = _Page()
        page.feed(path.read_text(encoding="utf-8", errors="replace"))
        cache[path] = page
    return cache[path]


def pages_of(site: Path) -> list[Path]:
    """The guide's pages: every HTML file but the generated API references'."""
    return [p for p in sorted(site.rglob("*.html")) if not p.relative_to(site).as_posix().startswith(SKIP_DIRS)]


def broken_links(site: Path) -> list[str]:
    """One message per broken link: `page: link (reason)`."""
    site = site.resolve()
    cache: dict[Path, _Page] = {}
    problems = []
    for page_path in pages_of(site):
        rel = page_path.relative_to(site).as_posix()
        for link in parse(page_path, cache).links:
            parts = urlsplit(link)
            if parts.scheme or link.startswith("//"):
                continue
            if not parts.path:
                target = page_path
            elif parts.path.startswith("/"):  # root-relative: the site is served at its root
                target = (site / unquote(parts.path).lstrip("/")).resolve()
            else:
                target = (page_path.parent / unquote(parts.path)).resolve()
            if parts.path.endswith("/") or target.is_dir():
                target = target / "index.html"
            if site not in target.parents and target != site:
                problems.append(f"{rel}: {link} (leaves the site)")
                continue
            if not target.is_file():
                problems.append(f"{rel}: {link} (no such file)")
                continue
            frag = unquote(parts.fragment)
            if frag and target.suffix == ".html" and frag not in parse(target, cache).ids:
                problems.append(f"{rel}: {link} (no anchor #{frag})")
    return problems


def main(argv: list[str]) -> int:
    if len(argv) != 2 or not Path(argv[1]).is_dir():
        print("usage: check_links.py SITE_DIR (a built site, e.g. target/book)", file=sys.stderr)
        return 2
    problems = broken_links(Path(argv[1]))
    for p in problems:
        print(f"broken link: {p}", file=sys.stderr)
    pages = len(pages_of(Path(argv[1]).resolve()))
    print(f"check_links: {pages} pages of the guide, {len(problems)} broken links")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
