#!/usr/bin/env python3
"""Checks HTML reports in headless Chromium: the page renders, logs no console error, holds the
elements asked for, and its screenshot is not blank.

    scripts/check-html.py [--expect-svg N | --figures-beside] [--expect-id ID]... [--shots DIR] PAGE.html...

Before the pages, the check is run on two pages of its own: a clean one (must pass) and one with a
console error and a broken script (must fail), so a Chromium that stopped reporting console errors
or rendering fails the check instead of passing it. Python standard library only (the PNG is
decoded with zlib). Exit status 0 when every page passes, 1 otherwise.
"""

import argparse
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

# Viewport of the screenshot: wide enough for the 900 px figures, tall enough for the verdict and
# the first tables.
WINDOW = "1200,1600"
# A rendered report has text, table rules and coloured boxes: far more than this many distinct
# colours, and far more than this share of non-background pixels. A blank or failed page has one
# colour (white, or Chromium's grey error page's few).
MIN_COLOURS = 16
MIN_INK_SHARE = 0.01
# Chromium's own start-up chatter on stderr that is not the page's (no GPU, no D-Bus in a
# container); console messages are told apart by their CONSOLE tag.
CONSOLE = re.compile(r"CONSOLE|Uncaught|SyntaxError|TypeError|ReferenceError")
TIMEOUT_S = 120


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    sys.exit("check-html: no chromium on PATH (Debian: apt-get install -y chromium)")


def run(browser, page, extra):
    """Runs headless Chromium on `page` with `extra` arguments; returns (stdout, stderr)."""
    url = "file://" + os.path.abspath(page)
    cmd = [
        browser,
        "--headless",
        "--disable-gpu",
        "--no-sandbox",
        "--hide-scrollbars",
        "--window-size=" + WINDOW,
        "--enable-logging=stderr",
        "--v=0",
        "--user-data-dir=" + tempfile.mkdtemp(prefix="check-html-profile-"),
        *extra,
        url,
    ]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"chromium exited {p.returncode}: {p.stderr.strip()[-2000:]}")
    return p.stdout, p.stderr


def png_pixels(path):
    """Decodes an 8-bit RGB or RGBA, non-interlaced PNG; returns (width, height, channels, rows)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, head = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    w, h, depth, colour, _, _, interlace = head
    channels = {2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace:
        raise ValueError(f"{path}: PNG depth {depth}, colour type {colour}, interlace {interlace}")
    raw = zlib.decompress(idat)
    stride = w * channels
    rows, prev = [], bytearray(stride)
    for y in range(h):
        filt = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if filt == 1:
                line[i] = (line[i] + a) & 255
            elif filt == 2:
                line[i] = (line[i] + b) & 255
            elif filt == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif filt == 4:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, channels, rows


def ink(path):
    """Distinct colours and the share of pixels that differ from the most common one."""
    w, h, ch, rows = png_pixels(path)
    counts = {}
    for row in rows:
        for i in range(0, len(row), ch):
            px = row[i : i + 3]
            counts[px] = counts.get(px, 0) + 1
    background = max(counts.values())
    return len(counts), 1.0 - background / (w * h)


def check(browser, page, shot, expect_svg, expect_ids):
    """Returns the list of problems with `page` (empty when it passes)."""
    problems = []
    _, err = run(browser, page, ["--screenshot=" + shot])
    console = [l for l in err.splitlines() if CONSOLE.search(l)]
    problems += [f"console: {l.strip()}" for l in console]
    dom, err = run(browser, page, ["--dump-dom"])
    problems += [f"console: {l.strip()}" for l in err.splitlines() if CONSOLE.search(l) and l not in console]
    if "</body>" not in dom:
        problems.append("the DOM dump has no body: the page did not load")
    svgs = len(re.findall(r"<svg[\s>]", dom))
    if expect_svg is not None and svgs != expect_svg:
        problems.append(f"{svgs} inline SVG figures rendered, expected {expect_svg}")
    for i in expect_ids:
        if f'id="{i}"' not in dom:
            problems.append(f'no element with id="{i}" in the rendered page')
    for ref in re.findall(r'(?:src|href)="(https?:[^"]*)"', dom):
        problems.append(f"external resource {ref}: the page must be self-contained")
    if not os.path.exists(shot):
        problems.append("no screenshot written")
    else:
        colours, share = ink(shot)
        print(f"  {page}: screenshot {shot}: {colours} colours, {100 * share:.1f} % ink, {svgs} SVG")
        if colours < MIN_COLOURS or share < MIN_INK_SHARE:
            problems.append(f"blank screenshot: {colours} colours, {100 * share:.2f} % non-background")
    return problems


def self_test(browser, tmp):
    """The check must pass a clean page and fail a broken one."""
    good = os.path.join(tmp, "good.html")
    bad = os.path.join(tmp, "bad.html")
    body = "<h1 id='verdict'>check</h1><div style='background:#0072b2;height:200px'></div>" + "".join(
        f"<p style='color:rgb({i * 9},{255 - i * 9},{i * 4})'>line {i} of coloured text</p>" for i in range(28)
    )
    with open(good, "w", encoding="utf-8") as f:
        f.write(f"<!DOCTYPE html><html><body>{body}</body></html>")
    with open(bad, "w", encoding="utf-8") as f:
        f.write(f"<!DOCTYPE html><html><body>{body}<script>console.error('boom'); undefinedFn();</script></body></html>")
    if p := check(browser, good, os.path.join(tmp, "good.png"), None, ["verdict"]):
        sys.exit(f"check-html: self-test: a clean page fails the check: {p}")
    if not any(x.startswith("console:") for x in check(browser, bad, os.path.join(tmp, "bad.png"), None, [])):
        sys.exit("check-html: self-test: a page with a console error passes the check (Chromium logged none)")
    blank = os.path.join(tmp, "blank.html")
    with open(blank, "w", encoding="utf-8") as f:
        f.write("<!DOCTYPE html><html><body></body></html>")
    if not any(x.startswith("blank") for x in check(browser, blank, os.path.join(tmp, "blank.png"), None, [])):
        sys.exit("check-html: self-test: a blank page passes the check")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pages", nargs="+", metavar="PAGE.html")
    ap.add_argument("--expect-svg", type=int, help="number of inline SVG figures each page must render")
    ap.add_argument(
        "--figures-beside",
        action="store_true",
        help="each page must render as many inline SVG figures as there are .svg files in its folder",
    )
    ap.add_argument("--expect-id", action="append", default=[], metavar="ID", help="an element id each page must have")
    ap.add_argument("--shots", metavar="DIR", help="keep the screenshots here (default: a temporary folder)")
    args = ap.parse_args()
    browser = chromium()
    tmp = tempfile.mkdtemp(prefix="check-html-")
    shots = args.shots or tmp
    os.makedirs(shots, exist_ok=True)
    self_test(browser, tmp)
    failed = False
    for n, page in enumerate(args.pages):
        if not os.path.isfile(page):
            print(f"check-html: {page}: no such file", file=sys.stderr)
            failed = True
            continue
        shot = os.path.join(shots, f"{n}-{os.path.splitext(os.path.basename(page))[0]}.png")
        expect_svg = args.expect_svg
        if args.figures_beside:
            folder = os.path.dirname(os.path.abspath(page))
            expect_svg = sum(1 for f in os.listdir(folder) if f.endswith(".svg"))
        for p in check(browser, page, shot, expect_svg, args.expect_id):
            print(f"check-html: {page}: {p}", file=sys.stderr)
            failed = True
    if failed:
        sys.exit(1)
    print(f"check-html: {len(args.pages)} page(s) render with no console error")


if __name__ == "__main__":
    main()
