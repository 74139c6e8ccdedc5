#!/usr/bin/env python3
"""Tables of the diagnosis's heading margin per field of view (examples/margin/fov.sh).

    python3 examples/margin/fov_table.py OUT

OUT holds fov.sh's folders: OUT/<field>/seed<N>.diag/diagnosis.json (and wall_s),
OUT/peer/<capture>.diag/. Standard library only. Per field of view, over its captures'
final frames (the diagnosis's last step; error = heading_error_deg, the fitted heading
minus the capture's reference):

  widening    heading_margin[].widen over all frames: median (min–max), and by which
              candidate (`by`), frames per candidate
  ρ from w    √(1 − 1/w²) at the median widening: the heading's correlation with the
              candidate that gives a widening w when the candidate is one parameter
              (derived from w, not read from a covariance)
  pooled      RMS of the 1σ over all frames / RMS of the errors over all frames, for the
              model's own 1σ (fit_sigma_deg) and the widened one (heading_sigma_deg)
  per capture r = RMS of its 8 frames' 1σ / RMS of its 8 errors; median (min–max) over
              the captures. Where the 1σ is exact, r's median is √(n/median χ²_n)
              (1.044 for n = 8), not 1: the 8-error RMS is low more often than high
  ≤ 2×        captures whose widened r ≤ 2; beside it the fraction expected were the
              model's own 1σ exact and every frame widened by the median w:
              P(χ²_n ≥ n·w²/4)
  within 2σ   frames with |error| ≤ 2·1σ, the model's own and widened
  named       captures whose diagnosis names an effect (remains.named) or calls the
              capture unexplained
  wall        the diagnose command's wall time (fov.sh's wall_s), median (min–max)
"""
import json
import math
import os
import sys


def chi2_cdf_even(x, n):
    """P(χ²_n ≤ x) for even n: 1 − e^{−x/2} Σ_{k<n/2} (x/2)^k / k!."""
    h = x / 2.0
    term, total = 1.0, 0.0
    for k in range(n // 2):
        if k:
            term *= h / k
        total += term
    return 1.0 - math.exp(-h) * total


def chi2_median_even(n):
    lo, hi = 0.0, 10.0 * n
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if chi2_cdf_even(mid, n) < 0.5:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def rms(xs):
    return math.sqrt(sum(x * x for x in xs) / len(xs))


def median(xs):
    s = sorted(xs)
    m = len(s) // 2
    return s[m] if len(s) % 2 else 0.5 * (s[m - 1] + s[m])


def load(diag_dir):
    d = json.load(open(os.path.join(diag_dir, "diagnosis.json")))
    frames = d["steps"][-1]["frames"]
    margin = d["heading_margin"]
    err = []
    for f in frames:
        e = f.get("heading_error_deg")
        if e is None:
            e = (f["heading_deg"] - f["reference_deg"] + 180.0) % 360.0 - 180.0
        err.append(e)
    wall = None
    p = os.path.join(diag_dir, "wall_s")
    if os.path.exists(p):
        wall = float(open(p).read())
    rem = d.get("remains") or {}
    named = list(rem.get("named") or []) + list(d.get("selected") or [])
    return {
        "err": err,
        "sigma": [f["heading_sigma_deg"] for f in frames],
        "own": [m["fit_sigma_deg"] for m in margin],
        "widen": [m["widen"] for m in margin],
        "by": [m["by"] for m in margin],
        "named": sorted(set(str(x) if not isinstance(x, dict) else x.get("effect", str(x)) for x in named)),
        "unexplained": bool(d.get("unexplained")),
        "wall": wall,
        "total_s": d.get("timings", {}).get("total_s"),
    }


def within(err, sig, k=2.0):
    return sum(abs(e) <= k * s for e, s in zip(err, sig))


def field_row(name, caps):
    n = len(caps[0]["err"])
    med_chi2 = chi2_median_even(n)
    widen = [w for c in caps for w in c["widen"]]
    by = {}
    for c in caps:
        for b in c["by"]:
            by[b or "none"] = by.get(b or "none", 0) + 1
    w_med = median(widen)
    rho = math.sqrt(max(0.0, 1.0 - 1.0 / w_med**2))
    err = [e for c in caps for e in c["err"]]
    own = [s for c in caps for s in c["own"]]
    sig = [s for c in caps for s in c["sigma"]]
    r_own = [rms(c["own"]) / rms(c["err"]) for c in caps]
    r_wid = [rms(c["sigma"]) / rms(c["err"]) for c in caps]
    le2 = sum(r <= 2.0 for r in r_wid)
    expect = 1.0 - chi2_cdf_even(n * w_med**2 / 4.0, n)
    named = sum(bool(c["named"]) or c["unexplained"] for c in caps)
    names = sorted({x for c in caps for x in c["named"]})
    walls = [c["wall"] for c in caps if c["wall"] is not None]
    wall = f"{median(walls):.1f} ({min(walls):.1f}–{max(walls):.1f})" if walls else "—"
    bys = ", ".join(f"{k} {v}" for k, v in sorted(by.items(), key=lambda kv: -kv[1]))
    return (
        f"| {name} | {len(caps)} × {n} | {w_med:.2f} ({min(widen):.2f}–{max(widen):.2f}) | {bys} | {rho:.2f} "
        f"| {rms(err):.5f} | {rms(sig):.5f} | {rms(own) / rms(err):.2f} | {rms(sig) / rms(err):.2f} "
        f"| {median(r_own):.2f} ({min(r_own):.2f}–{max(r_own):.2f}) "
        f"| {median(r_wid):.2f} ({min(r_wid):.2f}–{max(r_wid):.2f}) "
        f"| {le2}/{len(caps)} ({expect:.0%}) "
        f"| {sum(within(c['err'], c['own']) for c in caps)}/{len(err)} "
        f"| {sum(within(c['err'], c['sigma']) for c in caps)}/{len(err)} "
        f"| {named}/{len(caps)}{' (' + ', '.join(names) + ')' if names else ''} | {wall} |"
    ), med_chi2


def peer_row(name, c):
    n = len(c["err"])
    by = sorted({b or "none" for b in c["by"]})
    names = ", ".join(c["named"]) or "nothing"
    if c["unexplained"]:
        names += " (unexplained)"
    wall = f"{c['wall']:.1f}" if c["wall"] is not None else "—"
    return (
        f"| {name} | {n} | {rms(c['err']):.4f} | {min(c['widen']):.2f}–{max(c['widen']):.2f} ({', '.join(by)}) "
        f"| {rms(c['own']) / rms(c['err']):.2f} | {rms(c['sigma']) / rms(c['err']):.2f} "
        f"| {within(c['err'], c['own'])}/{n} | {within(c['err'], c['sigma'])}/{n} "
        f"| {max(abs(e) / s for e, s in zip(c['err'], c['sigma'])):.1f} | {names} | {wall} |"
    )


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    order = ["pinhole-8mm", "pinhole-4mm", "equidistant-3.6mm", "equidistant-2.7mm"]
    fields = [f for f in os.listdir(out) if f != "peer" and os.path.isdir(os.path.join(out, f))]
    fields.sort(key=lambda f: (order.index(f) if f in order else len(order), f))
    print(
        "| lens | captures × frames | widening median (range) | by (frames) | ρ from w "
        "| RMS error (°) | RMS widened 1σ (°) | model 1σ / RMS, pooled | widened 1σ / RMS, pooled "
        "| model r per capture, median (range) | widened r per capture, median (range) "
        "| captures widened r ≤ 2 (expected) | within 2σ, model | within 2σ, widened "
        "| captures named | diagnose wall s, median (range) |"
    )
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    med = None
    for f in fields:
        d = os.path.join(out, f)
        caps = [load(os.path.join(d, x)) for x in sorted(os.listdir(d)) if x.endswith(".diag")]
        if caps:
            row, med = field_row(f, caps)
            print(row)
    if med is not None:
        print(f"\n(r's median where the 1σ is exact: √(8/{med:.3f}) = {math.sqrt(8 / med):.3f})")
    peer = os.path.join(out, "peer")
    if os.path.isdir(peer):
        print(
            "\n| capture | frames | RMS error (°) | widening (by) | model 1σ / RMS | widened 1σ / RMS "
            "| within 2σ, model | within 2σ, widened | worst \\|err\\|/1σ widened | named | wall s |"
        )
        print("|---|---:|---:|---|---:|---:|---:|---:|---:|---|---:|")
        for x in sorted(os.listdir(peer)):
            if x.endswith(".diag") and os.path.exists(os.path.join(peer, x, "diagnosis.json")):
                print(peer_row(x[: -len(".diag")], load(os.path.join(peer, x))))


if __name__ == "__main__":
    main()
