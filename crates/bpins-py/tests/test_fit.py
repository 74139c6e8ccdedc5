"""fit and diagnose from Python: the same data as the CLI's fit.json and
diagnosis.json (one schema), the hidden effect of a sample found, and bad
arguments refused with their name."""

import json
import subprocess

import pytest

import bpins


def cli_json(cli, args, out, name):
    subprocess.run([cli, *args, "--out", str(out)], check=True, capture_output=True)
    return json.loads((out / name).read_text())


def same(a, b, at="$"):
    """Where two JSON values differ (None: nowhere); numbers to 1e-9 relative."""
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return f"{at}: keys {sorted(a)} vs {sorted(b)}"
        return next((d for k in a if (d := same(a[k], b[k], f"{at}.{k}"))), None)
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{at}: {len(a)} vs {len(b)} items"
        return next((d for i, (x, y) in enumerate(zip(a, b)) if (d := same(x, y, f"{at}[{i}]"))), None)
    if isinstance(a, float) and isinstance(b, float):
        return None if abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b)) else f"{at}: {a} vs {b}"
    return None if a == b else f"{at}: {a!r} vs {b!r}"


def test_fit_returns_the_cli_fit_json(samples, cli, tmp_path):
    cap = samples / "hidden-analyzer-angles"
    got = bpins.fit(cap, ["analyzer_angles"])
    want = cli_json(cli, ["fit", str(cap), "--effects", "analyzer_angles"], tmp_path / "fit", "fit.json")
    assert got.keys() == want.keys()
    assert got["effects"] == want["effects"] == ["analyzer_angles"]
    # The same fit, to 1e-9.
    assert same(got, want) is None, same(got, want)
    params = {p["name"]: p for p in got["params"]}
    # The sample's truth: d45 = +1.0°, d135 = −0.6°, recovered within 3σ.
    for name, truth in [("analyzer_angles.d45_deg", 1.0), ("analyzer_angles.d135_deg", -0.6)]:
        p = params[name]
        assert p["unit"] == "deg"
        assert abs(p["value"] - truth) <= 3.0 * p["sigma"], p
    assert 0.9 < got["chi2_per_dof"] < 1.1
    assert len(got["frames"]) == 8


def test_diagnose_names_the_hidden_effect_as_the_cli_does(samples, cli, tmp_path):
    cap = samples / "hidden-analyzer-angles"
    got = bpins.diagnose(cap, max_added=1)
    want = cli_json(cli, ["diagnose", str(cap), "--max-added", "1"], tmp_path / "d", "diagnosis.json")
    # Where the time went differs run to run: the same stages, not the same seconds.
    assert got.pop("timings").keys() == want.pop("timings").keys()
    assert same(got, want) is None, same(got, want)
    assert got["selected"] == ["analyzer_angles"]
    assert got["unexplained"] is False
    assert isinstance(got["unexplained_summary"], str)
    # Each step carries fit.json's fields beside its model.
    assert got["steps"][-1]["model"] == ["analyzer_angles"]
    assert got["steps"][-1]["chi2_per_dof"] < 1.1


def test_a_colour_captures_fit_models_its_bands_as_the_cli_does(cli, tmp_path):
    """`bpins.fit` of a colour capture that names no band effect fits `sky_spectrum` too
    (its bands differ in level and DoLP), says so in "added", and is the CLI's fit.json;
    naming `band_response` adds nothing (docs/colour.md, "Fitting and diagnosing one")."""
    cap = tmp_path / "colour"
    # A blue sky through RGGB filters (tests/colour.rs' BLUE_SKY), 128 × 96, two frames.
    sky = ["sky_spectrum.radiance_r=0.625", "sky_spectrum.radiance_b=1.25", "sky_spectrum.dmax_r=1.0571",
           "sky_spectrum.dmax_b=0.8857", "band_response.qe_r=0.8", "band_response.qe_b=0.6667"]
    args = ["simulate", "--out", str(cap), "--colour-tiles", "RGGB", "--width-px", "128", "--height-px", "96",
            "--pixel-pitch-um", "66", "--sun-azimuth-deg", "200", "--sun-elevation-deg", "45",
            "--headings-deg", "7,97", "--dmax", "0.70", "--read-noise-dn", "1", "--system-gain-dn-per-e", "0.1",
            "--seed", "1"]
    for e in sky:
        args += ["--effect", e]
    subprocess.run([cli, *args], check=True, capture_output=True)
    got = bpins.fit(cap)
    want = cli_json(cli, ["fit", str(cap)], tmp_path / "fit", "fit.json")
    assert same(got, want) is None, same(got, want)
    assert got["effects"] == ["sky_spectrum"]
    assert [a["effect"] for a in got["added"]] == ["sky_spectrum"] and "colour_tiles" in got["added"][0]["why"]
    assert 0.8 < got["chi2_per_dof"] < 1.3
    for f in got["frames"]:
        assert abs(f["heading_error_deg"]) < 3.0 * f["heading_sigma_deg"], f
    named = bpins.fit(cap, ["band_response"])
    assert named["effects"] == ["band_response"] and "added" not in named


def test_bad_fit_arguments_name_themselves(samples, tmp_path):
    cap = samples / "clean"
    with pytest.raises(ValueError, match="effects: unknown effect `no_such_effect`"):
        bpins.fit(cap, ["no_such_effect"])
    with pytest.raises(TypeError):
        bpins.fit(cap, "analyzer_angles")  # a str, not a list of names
    with pytest.raises(ValueError, match="fixed_dmax"):
        bpins.fit(cap, fixed_dmax=float("nan"))
    with pytest.raises(ValueError, match="fixed_dmax"):
        bpins.diagnose(cap, fixed_dmax=1.5)
    with pytest.raises(ValueError, match="sample_budget_px = 10"):
        bpins.fit(cap, sample_budget_px=10)
    with pytest.raises(FileNotFoundError, match="no-capture-here/capture.toml: not found"):
        bpins.fit(tmp_path / "no-capture-here")


def test_a_mixed_twilight_is_fitted_with_both_skies_and_a_dark_night_refused_naming_the_frame(cli, tmp_path):
    # The sun at −12.4° and a 75 % moon each give half the sky's light (docs/night.md,
    # "Twilight"): fitted with both skies, as `bpins fit` fits it, the moon's strength a
    # nuisance per frame near the simulated 1; a dark night is refused.
    def simulate(name, time):
        cap = tmp_path / name
        subprocess.run([cli, "simulate", "--out", str(cap), "--time-utc", time, "--latitude-deg",
                        "36.07", "--longitude-deg", "120.38", "--width-px", "128", "--height-px", "128",
                        "--pixel-pitch-um", "27.6", "--headings-deg", "20,200", "--scene", "twilight"],
                       check=True, capture_output=True)
        return cap
    got = bpins.fit(simulate("mixed", "2026-06-24T12:30:00Z"))
    for f, k in zip(got["frames"], got["sky"]):
        assert abs(f["heading_error_deg"]) <= 3.0 * f["heading_sigma_deg"], f
        assert abs(f["twilight_strength"] - 1.0) < 0.05, f
        assert k["mixed"] is True and k["source"] == "sun", k
    dark = simulate("dark", "2026-07-14T16:00:00Z")
    for run in (bpins.fit, bpins.diagnose):
        with pytest.raises(ValueError, match="frames/f000.png") as e:
            run(dark)
        assert "not yet: the moon is at -30.7° and the sun at -32.3°" in str(e.value)
