"""What the scripts that measure a table for the documentation share: where the pages and
figures live, the --page argument, and the text between a pair of markers of a page."""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
FIGURES = DOCS / "figures"


def add_page_argument(parser, page, default=True):
    """--page PATH: the page whose markers the tables go between (default docs/PAGE, or
    none if not ``default``)."""
    parser.add_argument("--page", type=Path, default=DOCS / page if default else None,
                        help=f"write the tables into this page (the site's: docs/{page})")


def write_between_markers(page, name, text):
    """Replace what lies between <!-- NAME:start --> and <!-- NAME:end --> in ``page``."""
    markers = re.compile(rf"(<!-- {name}:start -->\n).*?(<!-- {name}:end -->)", re.S)
    content = page.read_text()
    if not markers.search(content):
        sys.exit(f"{page}: no {name} markers")
    page.write_text(markers.sub(lambda m: m[1] + text + m[2], content))
