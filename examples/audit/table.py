#!/usr/bin/env python3
"""The 1σ audit's table (docs/honesty.md) from the JSON files examples/audit/run.sh wrote.

One row per route × capture (× extractor, × band for a colour capture): frames with a
heading, RMS error, median 1σ, frames within 2σ, the worst |error|/1σ; flagged (!) where
fewer than 90 % are within 2σ or the worst exceeds 3σ. Standard library only.

    python3 examples/audit/table.py OUT... [--markdown | --matrix]
"""
import glob
import json
import math
import os
import re
import statistics
import sys


def wrap180(x):
    return (x + 180.0) % 360.0 - 180.0


def row(route, capture, key, errs_sigmas, missing=0):
    """errs_sigmas: [(error_deg, sigma_deg)] of the frames with a heading."""
    n = len(errs_sigmas)
    if n == 0:
        return dict(route=route, capture=capture, key=key, n=0, missing=missing)
    errs = [e for e, _ in errs_sigmas]
    z = [abs(e) / s if s > 0 else math.inf for e, s in errs_sigmas]
    within = sum(1 for v in z if v <= 2.0)
    zrms = math.sqrt(sum(v * v for v in z) / n)
    return dict(
        route=route, capture=capture, key=key, n=n, missing=missing,
        rms=math.sqrt(sum(e * e for e in errs) / n),
        med_sigma=statistics.median(s for _, s in errs_sigmas),
        within=within, worst=max(z), zrms=zrms,
        flag=within < 0.9 * n or max(z) > 3.0,
    )


def heading_rows(out):
    rows = []
    pooled = {}
    for path in sorted(glob.glob(os.path.join(out, "heading.*.json")) +
                       glob.glob(os.path.join(out, "plain-*.*.json"))):
        base = os.path.basename(path)[: -len(".json")]
        route, capture = base.split(".", 1)
        route = "field" if route == "heading" else route
        # a simulation's seeds (sim-NAME-sK) pooled into one row
        capture = re.sub(r"^(sim-.*)-s[0-9]+$", r"\1 (seeds)", capture)
        data = json.load(open(path))
        groups = pooled.setdefault((route, capture), {})
        for f in data["frames"]:
            key = f.get("extractor") or "-"
            if f.get("band"):
                key += "/" + f["band"]
            g = groups.setdefault(key, ([], [0]))
            if f.get("heading_deg") is None or f.get("sigma_deg") is None:
                g[1][0] += 1
            elif f.get("error_deg") is not None:
                g[0].append((wrap180(f["error_deg"]), f["sigma_deg"]))
    for (route, capture), groups in pooled.items():
        for key, (es, miss) in groups.items():
            rows.append(row(route, capture, key, es, miss[0]))
    # The mono demosaic route's 1σ carries the design effect of its bilinear samples
    # (√F = 8/3, pipeline.rs `demosaic_design_effect`) since bpins applies it; JSON
    # written before that reads 8/3 too small here.
    return rows


def fit_rows(out):
    rows = []
    for path in sorted(glob.glob(os.path.join(out, "fit.*", "fit.json"))):
        capture = os.path.basename(os.path.dirname(path))[len("fit."):]
        data = json.load(open(path))
        es = [(wrap180(f["heading_error_deg"]), f["heading_sigma_deg"])
              for f in data["frames"] if f.get("heading_error_deg") is not None]
        rows.append(row("fit", capture, "chi2/dof %.3g" % data["chi2_per_dof"], es))
    return rows


def diagnose_rows(out):
    rows = []
    for path in sorted(glob.glob(os.path.join(out, "diagnose.*", "diagnosis.json"))):
        capture = os.path.basename(os.path.dirname(path))[len("diagnose."):]
        data = json.load(open(path))
        for key, es in diagnose_frames(data):
            rows.append(row("diagnose", capture, key, es))
    return rows


def diagnose_frames(data):
    """(label, [(error, sigma)]) of the final step: its 1σ widened by the margin
    (`heading_sigma_deg`) and the final fit's before the margin (`heading_margin[].fit_sigma_deg`)."""
    final = data["steps"][-1]
    frames = final["frames"]
    # the final model (an effect confusable with another stays in it, unnamed)
    named = "+".join(final.get("model") or []) or "no effect"
    if data.get("unexplained"):
        named += ", unexplained"
    margin = data.get("heading_margin") or [{}] * len(frames)
    out = []
    es = [(wrap180(f["heading_error_deg"]), f["heading_sigma_deg"]) for f in frames
          if f.get("heading_error_deg") is not None]
    out.append(("widened; %s" % named, es))
    es = [(wrap180(f["heading_error_deg"]), m["fit_sigma_deg"]) for f, m in zip(frames, margin)
          if f.get("heading_error_deg") is not None and m.get("fit_sigma_deg")]
    if es:
        out.append(("before margin; %s" % named, es))
    return out


def locate_rows(out):
    es_north, es_lat, es_lon = [], [], []
    for path in sorted(glob.glob(os.path.join(out, "locate.*.json"))):
        data = json.load(open(path))
        ans, err = data.get("located"), data.get("errors")
        if not ans or not err:
            continue
        es_north.append((wrap180(err["heading_deg"]), ans["heading_sigma_deg"]))
        es_lat.append((err["latitude_deg"], ans["latitude_sigma_deg"]))
        es_lon.append((wrap180(err["longitude_deg"]), ans["longitude_sigma_deg"]))
    if not es_north:
        return []
    return [row("locate", "sim (seeded hours)", k, es)
            for k, es in (("north", es_north), ("latitude", es_lat), ("longitude", es_lon))]


# --matrix: one row per capture, one column per route (sun_vector; a colour capture's fused
# heading); a cell "within 2σ / frames, worst |err|/σ (RMS error ° / median 1σ °)".
COLUMNS = [
    ("field sun_vector", "field", "sun_vector"),
    ("field meridian_line", "field", "meridian_line"),
    ("plain demosaic", "plain-demosaic", "sun_vector"),
    ("plain superpixel", "plain-superpixel", "sun_vector"),
    ("fit", "fit", None),
    ("diagnose (widened)", "diagnose", "widened"),
]


def matrix(rows):
    captures = []
    for r in rows:
        if r["route"] != "locate" and r["capture"] not in captures:
            captures.append(r["capture"])

    def cell(capture, route, key):
        for r in rows:
            if r["route"] != route or r["capture"] != capture or r["n"] == 0:
                continue
            k = r["key"]
            if key is None or k in (key, key + "/fused") or (route == "diagnose" and k.startswith(key + ";")):
                mark = " **!**" if r["flag"] else ""
                return "%d/%d, %.1f (%.4f / %.4f)%s" % (r["within"], r["n"], r["worst"], r["rms"], r["med_sigma"], mark)
        return "—"

    print("| capture | " + " | ".join(c[0] for c in COLUMNS) + " |")
    print("|---" * (len(COLUMNS) + 1) + "|")
    for cap in captures:
        print("| %s | " % cap + " | ".join(cell(cap, route, key) for _, route, key in COLUMNS) + " |")


def seed_differences(out):
    """The noise part of each route's 1σ alone: on the seeded simulations (the same
    headings under every seed), the RMS over seed pairs of (e1 − e2)/√(σ1² + σ2²), which a
    bias common to the seeds cancels from; 1 where the 1σ is the noise's (sun_vector; a
    colour capture's fused heading)."""
    lines = []
    for route in ("heading", "plain-demosaic", "plain-superpixel"):
        for g in sorted({os.path.basename(p).split(".")[1].rsplit("-s", 1)[0]
                         for p in glob.glob(os.path.join(out, route + ".sim-*-s*.json"))}):
            runs = []
            for path in sorted(glob.glob(os.path.join(out, "%s.%s-s*.json" % (route, g)))):
                frames = json.load(open(path))["frames"]
                runs.append({f["file"]: (f["error_deg"], f["sigma_deg"]) for f in frames
                             if f["extractor"] == "sun_vector" and f.get("band") in (None, "fused")
                             and f.get("sigma_deg") and f.get("error_deg") is not None})
            z = [(a[k][0] - b[k][0]) / math.hypot(a[k][1], b[k][1])
                 for i, a in enumerate(runs) for b in runs[i + 1:] for k in a if k in b]
            if z:
                name = "field" if route == "heading" else route
                lines.append("%-17s %-22s seed pairs %4d: RMS (e1 - e2)/sqrt(s1^2 + s2^2) %.2f"
                             % (name, g, len(z), math.sqrt(sum(v * v for v in z) / len(z))))
    return lines


def main():
    md = "--markdown" in sys.argv
    rows = []
    for out in [a for a in sys.argv[1:] if not a.startswith("--")]:
        rows += heading_rows(out) + fit_rows(out) + diagnose_rows(out) + locate_rows(out)
    if "--matrix" in sys.argv:
        matrix(rows)
        return
    if md:
        print("| route | capture | extractor/band | frames | RMS err (°) | median 1σ (°) | within 2σ | worst \\|err\\|/σ | RMS err/σ | |")
        print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["n"] == 0:
            line = (r["route"], r["capture"], r["key"], "0 (%d without)" % r["missing"], "", "", "", "", "", "")
        else:
            miss = " (+%d without)" % r["missing"] if r["missing"] else ""
            line = (r["route"], r["capture"], r["key"], "%d%s" % (r["n"], miss), "%.4f" % r["rms"],
                    "%.4f" % r["med_sigma"], "%d/%d" % (r["within"], r["n"]), "%.1f" % r["worst"], "%.2f" % r["zrms"],
                    "**!**" if md and r["flag"] else ("!" if r["flag"] else ""))
        if md:
            print("| " + " | ".join(line) + " |")
        else:
            print("%-17s %-22s %-30s %-14s %8s %8s %6s %6s %6s %s" % line)
    if not md:
        for out in [a for a in sys.argv[1:] if not a.startswith("--")]:
            for line in seed_differences(out):
                print(line)


if __name__ == "__main__":
    main()
