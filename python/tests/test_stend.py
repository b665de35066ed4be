"""The Python module against the program: the same input through `stend` and through `import stend`
gives equal numbers, equal verdicts and equal errors (messages and exit codes)."""
import json
import math

import numpy as np
import pytest
import yaml

import stend

PAPER_MODEL = "estimators/batch_lsq/examples/paper_z_channel.yaml"
ALLAN_MODEL = "estimators/allan/example/allan.yaml"


def same_number(a, b):
    return (a is None and b is None) or (a is not None and b is not None and (a == b or (math.isnan(a) and math.isnan(b))))


def same_samples(a, b):
    """Every field of two structured arrays equal (NaN equal to NaN: an absent temperature)."""
    return len(a) == len(b) and all(
        np.array_equal(a[f], b[f], equal_nan=a.dtype[f].base.kind == "f") for f in a.dtype.names)


def parameters(listed):
    """(name, unit, value, std_error, interval, verdict) of each parameter of a results document
    (or of FitResult.to_dict(), which names the value "estimate"); null for what was not estimated."""
    def interval(p):
        return None if p["interval"] in (None, [None, None]) else list(p["interval"])
    return [(p["name"], p["unit"], p.get("value", p.get("estimate")), p["std_error"], interval(p), p["verdict"])
            for p in listed]


def test_version(cli):
    assert stend.__version__
    assert cli("--version").stdout.startswith("stend " + stend.__version__)


# ---- recordings ---------------------------------------------------------------------------------

def test_open_matches_info(cli, paper_run):
    rec = stend.open(paper_run)
    _, info, _ = cli.json("info", paper_run)
    assert rec.header == {k: v for k, v in info.items() if k not in ("segments", "events")}
    assert rec.events == info["events"]
    assert len(rec) == info["samples"]
    samples = rec.samples
    assert samples.dtype == stend.SAMPLE_DTYPE and samples["accel_mps2"].shape == (len(rec), 3)
    assert samples["t_s"][0] == info["t_first_s"] and samples["t_s"][-1] == info["t_last_s"]
    seg = rec.segments
    assert len(seg) == len(info["segments"])
    assert [s["t_start_s"] for s in info["segments"]] == seg["t_start_s"].tolist()
    assert [s["kind"] for s in info["segments"]] == seg["kind"].tolist()
    truth = rec.truth
    assert len(truth) == info["truth_rows"] and "t_s" in truth.dtype.names


def test_chunks_read_the_same_samples(paper_run):
    rec = stend.open(paper_run)
    chunks = list(rec.chunks(10_000))
    assert all(len(c) <= 10_000 for c in chunks)
    assert same_samples(np.concatenate(chunks), rec.samples)
    assert same_samples(np.concatenate(list(rec.chunks(777, first=5, last=5000))), rec.samples[5:5000])


def test_import_matches_the_program(cli, scratch):
    # A CSV log of raw counts written here: ms time, counts around 32768, as the README's example.
    n = 2000
    rng = np.random.default_rng(1)
    t_ms = np.arange(n) * 10.0
    acc = (np.array([0, 0, 16384]) + rng.normal(0, 30, (n, 3))).astype(int) + 32768
    gyr = rng.normal(0, 5, (n, 3)).astype(int) + 32768
    log = scratch / "log.csv"
    with open(log, "w") as f:
        f.write("t,ax,ay,az,gx,gy,gz\n")
        for k in range(n):
            f.write(f"{t_ms[k]:.0f},{','.join(map(str, acc[k]))},{','.join(map(str, gyr[k]))}\n")
    flags = ["--time", "t", "--time-unit", "ms", "--accel", "ax,ay,az", "--accel-lsb", "1/16384g", "--accel-offset",
             "32768", "--gyro", "gx,gy,gz", "--gyro-lsb", "1/131deg/s", "--gyro-offset", "32768"]
    code, doc, _ = cli.json("import", log, "-o", scratch / "log-cli", *flags)
    assert code == 0
    options = dict(time="t", time_unit="ms", accel=["ax", "ay", "az"], accel_lsb="1/16384g", accel_offset=32768,
                   gyro="gx,gy,gz", gyro_lsb="1/131deg/s", gyro_offset=32768)
    py_run = stend.import_(log, scratch / "log-py", **options)
    cli_run = stend.open(doc["run_dir"])
    assert len(py_run) == doc["samples"] == n
    assert same_samples(py_run.samples, cli_run.samples)
    in_memory = stend.import_(log, **options)  # no run folder: the samples in memory
    assert same_samples(in_memory.samples, cli_run.samples)
    assert in_memory.samples["accel_mps2"][:, 2].mean() == pytest.approx(9.80665, rel=1e-2)


# ---- errors -------------------------------------------------------------------------------------

def expect_same_error(cli_result, call):
    """The program's exit code and stderr against the exception the same call raises in Python."""
    with pytest.raises(stend.Error) as raised:
        call()
    assert raised.value.exit_code == cli_result.returncode != 0
    assert raised.value.message in cli_result.stderr
    return raised.value


def test_errors_match_the_program(cli, scratch, paper_run, source):
    missing = scratch / "no-such.csv"
    e = expect_same_error(cli("import", missing, "-o", scratch / "x", check=False), lambda: stend.import_(missing))
    assert isinstance(e, stend.InputError)
    e = expect_same_error(cli("import", missing, "-o", paper_run, check=False),
                          lambda: stend.import_(missing, paper_run))
    expect_same_error(cli("fit", paper_run, "--model", scratch / "no-model.yaml", check=False),
                      lambda: stend.fit(paper_run, scratch / "no-model.yaml"))
    expect_same_error(cli("gap", paper_run, "--model", source / ALLAN_MODEL, check=False),
                      lambda: stend.gap(paper_run, source / ALLAN_MODEL))
    # An import option's value is checked as the command line checks it: a usage error, exit 1.
    p = cli("import", missing, "-o", scratch / "y", "--accel-lsb", "bogus", check=False)
    with pytest.raises(stend.UsageError) as raised:
        stend.import_(missing, accel_lsb="bogus")
    assert p.returncode == raised.value.exit_code == 1
    assert raised.value.message.split(": ", 1)[1] in p.stderr
    with pytest.raises(stend.UsageError):
        stend.import_(missing, no_such_option=1)


# ---- fit ----------------------------------------------------------------------------------------

def test_fit_matches_the_program(cli, scratch, paper_run, source):
    code, doc, _ = cli.json("fit", paper_run, "--model", source / PAPER_MODEL, "--out", scratch / "fit-cli.json")
    r = stend.fit(stend.open(paper_run), source / PAPER_MODEL, out=scratch / "fit-py.json")
    assert r.exit_code == code == 0 and r.ok
    assert r.document == doc["document"]
    assert parameters(doc["document"]["parameters"]) == parameters(r.to_dict()["parameters"])
    assert json.load(open(scratch / "fit-py.json")) == json.load(open(scratch / "fit-cli.json"))
    n = len(r.instruments["accelerometer"].names)
    assert r.covariance.shape == (n, n) and np.allclose(r.covariance, r.covariance.T)
    # the standard errors are the covariance's diagonal, for every parameter estimated
    for name, var in zip(r.instruments["accelerometer"].names, np.diag(r.covariance)):
        p = next((p for p in r.parameters if p.name == name), None)
        if p is not None and p.identifiable and var > 0:
            assert math.sqrt(var) == pytest.approx(p.std_error, rel=1e-6)
    assert json.loads(r.to_json())["parameters"][0]["name"] == r.parameters[0].name
    assert r.summary in repr(r) and r.parameters[0].name in repr(r)
    # the model as a dict: the same fit
    with open(source / PAPER_MODEL) as f:
        as_dict = stend.fit(paper_run, yaml.safe_load(f), out=scratch / "fit-dict.json")
    assert [p.estimate for p in as_dict.parameters] == [p.estimate for p in r.parameters]


def test_failed_fit_is_a_result_with_the_programs_exit_code(cli, scratch, paper_run):
    model = {"instrument": "gyroscope", "terms": ["bias"]}  # the paper's run: a fit with nothing to see
    path = scratch / "gyro-bias.yaml"
    path.write_text(yaml.safe_dump(model))
    code, doc, _ = cli.json("fit", paper_run, "--model", path, "--out", scratch / "gyro-cli.json", check=False)
    r = stend.fit(paper_run, model, out=scratch / "gyro-py.json")
    assert r.exit_code == code
    assert r.status == doc["status"] and r.ok == doc["ok"]


def test_allan_fit_matches_the_program(cli, scratch, six_run, source):
    code, doc, _ = cli.json("fit", six_run, "--model", source / ALLAN_MODEL, "--out", scratch / "allan-cli.json",
                            check=False)
    r = stend.fit(six_run, source / ALLAN_MODEL, out=scratch / "allan-py.json")
    assert r.exit_code == code
    assert r.document == doc["document"]


# ---- run ----------------------------------------------------------------------------------------

def test_run_matches_the_program(scratch, paper_run, source):
    seen = []
    summary = stend.run(source / "configs/paper_mpu6050_z.yaml", output=scratch / "runs", name="paper-py",
                        progress=seen.append, progress_period_s=0.0)
    assert summary["status"] == "complete" and summary["exit_code"] == 0 and summary["fit"]["ok"]
    assert seen and seen[-1]["step_count"] >= 1 and "remaining_s" in seen[-1]
    py_fit = json.load(open(summary["run_dir"] + "/fit.json"))
    cli_fit = json.load(open(paper_run / "fit.json"))
    assert parameters(py_fit["parameters"]) == parameters(cli_fit["parameters"])  # same seed, same numbers
    assert same_samples(summary["recording"].samples, stend.open(paper_run).samples)


def test_run_stopped_by_the_callback(scratch, source):
    def stop(progress):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        stend.run(source / "configs/paper_mpu6050_z.yaml", output=scratch / "runs", name="stopped", progress=stop)
    rec = stend.open(scratch / "runs" / "stopped")
    assert rec.header["status"] == "interrupted"


def test_run_errors_match_the_program(cli, scratch):
    bad = scratch / "bad.yaml"
    bad.write_text("experiment: {name: bad}\nprocedure: []\n")
    expect_same_error(cli("run", bad, "--quiet", "--output", scratch / "runs", check=False),
                      lambda: stend.run(bad, output=scratch / "runs"))


# ---- apply, gap, export -------------------------------------------------------------------------

def test_apply_matches_the_program(cli, scratch, paper_run):
    cal = paper_run / "fit.json"
    # The paper's design does not see cross_zy: applying it as 0 is refused unless stated.
    expect_same_error(cli("apply", cal, paper_run, "-o", scratch / "cal-refused", check=False),
                      lambda: stend.apply(cal, paper_run, scratch / "cal-refused"))
    code, doc, _ = cli.json("apply", cal, paper_run, "-o", scratch / "cal-cli", "--assume", "cross_zy=0")
    assert code == 0
    program = stend.open(doc["calibrated"]).samples
    assume = "cross_zy=0"
    arrays = stend.apply(cal, stend.open(paper_run).samples, assume=assume)
    assert np.array_equal(arrays["accel_mps2"], program["accel_mps2"])
    from_dict = stend.apply(cal, {"accel_mps2": stend.open(paper_run).samples["accel_mps2"],
                                  "temperature_c": stend.open(paper_run).samples["temperature_c"]}, assume=[assume])
    assert np.array_equal(from_dict["accel_mps2"], program["accel_mps2"])
    py = stend.apply(cal, paper_run, scratch / "cal-py", assume=assume)
    assert py["ok"] and same_samples(stend.open(py["calibrated"]).samples, program)
    p = cli("apply", cal, paper_run, "--assume", assume, check=False)  # nothing to do: a usage error
    expect_same_error(p, lambda: stend.apply(cal, paper_run, assume=assume))


def test_apply_validation_matches_the_program(cli, scratch, paper_run):
    cal, assume = paper_run / "fit.json", "cross_zy=0"
    code, doc, _ = cli.json("apply", cal, paper_run, "--validate", "--assume", assume, "--validation-out",
                            scratch / "validation-cli.json", check=False)
    r = stend.apply(cal, paper_run, validate=True, assume=assume, validation_out=scratch / "validation-py.json")
    assert r["exit_code"] == code
    assert r["validation"]["verdict"] == doc["validation"]["verdict"]
    assert r["validation"]["document"] == doc["validation"]["document"]


def test_gap_matches_the_program(cli, scratch, six_run, source):
    model = source / "diagnosis/examples/bias_scale.yaml"
    code, doc, _ = cli.json("gap", six_run, "--model", model, "--out", scratch / "gap-cli.json", check=False)
    r = stend.gap(six_run, model, out=scratch / "gap-py.json")
    assert r["exit_code"] == code and r["ok"] == doc["ok"]
    assert r["document"] == doc["document"]


def test_export_matches_the_program(cli, scratch, paper_run):
    code, doc, _ = cli.json("export", paper_run, "--to", "json", "-o", scratch / "export-cli.json")
    r = stend.export(paper_run, "json", scratch / "export-py.json")
    assert len(r["files"]) == len(doc["files"]) == 1
    assert json.load(open(scratch / "export-py.json")) == json.load(open(scratch / "export-cli.json"))
    expect_same_error(cli("export", paper_run, "--to", "kalibr", "-o", scratch / "k.yaml", check=False),
                      lambda: stend.export(paper_run, "kalibr", scratch / "k.yaml"))
    # The paper's cross_zy is not excited: refused alike, and written alike with the value stated.
    expect_same_error(cli("export", paper_run, "--to", "imutk", "-o", scratch / "cli", check=False),
                      lambda: stend.export(paper_run, "imutk", scratch / "py"))
    code, doc, _ = cli.json("export", paper_run, "--to", "imutk", "-o", scratch / "cli", "--assume", "cross_zy=0")
    r = stend.export(paper_run, "imutk", scratch / "py", assume="cross_zy=0")
    assert r["notes"] == doc["notes"]
    assert open(scratch / "py_acc.calib").read() == open(scratch / "cli_acc.calib").read()


def test_deviations_match_the_program(cli, scratch):
    values = np.random.default_rng(3).normal(0, 1e-3, 4096)  # white frequency noise
    series = scratch / "series.txt"
    series.write_text("\n".join(f"{v:.17g}" for v in values) + "\n")
    code, doc, _ = cli.json("deviations", series, "--tau0", "0.01")
    from_file = stend.deviations(series, tau0_s=0.01)
    from_array = stend.deviations(values, tau0_s=0.01)
    assert from_file["exit_code"] == from_array["exit_code"] == code == 0
    assert from_file["deviations"] == doc["deviations"]
    assert from_array["deviations"] == doc["deviations"]
    expect_same_error(cli("deviations", series, check=False), lambda: stend.deviations(series))
    p = cli("deviations", scratch / "constant.txt", "--tau0", "1", check=False)  # absent file: the program's error
    expect_same_error(p, lambda: stend.deviations(scratch / "constant.txt", tau0_s=1))


def test_import_with_experiment_matches_the_program(cli, scratch, shared, source):
    log = shared / "imucal/annotated_session.csv"
    procedure = source / "configs/procedures/ferraris.yaml"
    code, doc, _ = cli.json("import", log, "--experiment", procedure, "-o", scratch / "ferraris-cli")
    py_run = stend.import_(log, scratch / "ferraris-py", experiment=procedure)
    cli_run = stend.open(doc["run_dir"])
    assert code == 0 and len(py_run) == doc["samples"]
    assert same_samples(py_run.segments, cli_run.segments)
    assert same_samples(py_run.truth, cli_run.truth)
    model = source / "estimators/ceres_nonlinear/examples/ferraris.yaml"
    code, fit_doc, _ = cli.json("fit", cli_run.path, "--model", model, "--out", scratch / "ferraris-cli.json")
    r = stend.fit(py_run, model, out=scratch / "ferraris-py.json")
    assert r.exit_code == code and parameters(fit_doc["document"]["parameters"]) == parameters(r.to_dict()["parameters"])
    # the same log in memory, aligned to the same procedure (as `stend fit LOG --experiment` reads it)
    in_memory = stend.import_(log, experiment=procedure)
    assert same_samples(in_memory.segments, cli_run.segments)
