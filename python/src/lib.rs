//! `lodestar._lodestar`: the Python extension module behind the `lodestar` package
//! (`python/lodestar/__init__.py` documents the user-facing functions; `docs/python.md` is the
//! guide).
//!
//! Renders run on their own thread with the GIL released. The calling thread wakes every
//! [`POLL`] to hand the progress to the caller's callback and to look for Ctrl-C
//! (`Python::check_signals`); a signal asks the render to stop after its pass under way
//! ([`lodestar::render::Control`]), waits for it, and raises `KeyboardInterrupt`.

use lodestar::bench::{BenchConfig, report};
use lodestar::film::Image;
use lodestar::integrators::{IntegratorParams, Options, RunSettings};
use lodestar::render::{Budget, Control};
use lodestar::scene::{Scene, loader};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// How often a waiting call looks for Ctrl-C and reports progress.
const POLL: Duration = Duration::from_millis(50);

fn err(e: lodestar::Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The scene: a file (TOML or Mitsuba XML, by extension), a TOML text, or the built-in
/// Cornell box.
fn load_scene(scene: Option<&str>, is_text: bool, defines: &[(String, String)]) -> PyResult<Scene> {
    match (scene, is_text) {
        (None, _) => {
            if let Some((k, _)) = defines.first() {
                return Err(PyValueError::new_err(format!(
                    "defines: '{k}' defines a Mitsuba XML parameter, but the built-in scene takes none"
                )));
            }
            Ok(Scene::cornell_box())
        }
        (Some(text), true) => {
            if let Some((k, _)) = defines.first() {
                return Err(PyValueError::new_err(format!(
                    "defines: '{k}' defines a Mitsuba XML parameter, but a TOML text takes none"
                )));
            }
            loader::load_str(text, "<scene text>", None).map_err(err)
        }
        (Some(path), false) => loader::load_file_with(Path::new(path), defines).map_err(err),
    }
}

/// Run `work` on its own thread with the GIL released; meanwhile hand `control`'s progress to
/// `progress` and turn Ctrl-C into a stop request and `KeyboardInterrupt`.
fn run_controlled<T: Send>(
    py: Python<'_>,
    control: &Control,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let progress: Option<Py<PyAny>> = progress.map(|p| p.clone().unbind());
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        s.spawn(move || {
            // The receiver outlives the scope's threads: a send cannot fail.
            let _ = tx.send(work());
        });
        py.detach(move || {
            let mut reported = -1.0f64;
            let mut interrupted: Option<PyErr> = None;
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(value) => {
                        if let Some(e) = interrupted {
                            return Err(e);
                        }
                        if let Some(cb) = &progress
                            && reported != 1.0
                        {
                            Python::attach(|py| cb.call1(py, (1.0f64,)))?;
                        }
                        return Ok(value);
                    }
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(PyRuntimeError::new_err("the render thread panicked"));
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                }
                if interrupted.is_some() {
                    continue;
                }
                // Ctrl-C, or an exception raised by the callback: stop after the pass under
                // way, wait for the render, raise.
                let outcome = Python::attach(|py| {
                    py.check_signals()?;
                    if let Some(cb) = &progress {
                        let p = control.progress();
                        if p != reported {
                            reported = p;
                            cb.call1(py, (p,))?;
                        }
                    }
                    Ok::<(), PyErr>(())
                });
                if let Err(e) = outcome {
                    control.stop();
                    interrupted = Some(e);
                }
            }
        })
    })
}

/// A statistic's value as a Python int or float where it reads as one, else its text.
fn stat_value<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    if let Ok(i) = text.parse::<i64>() {
        return Ok(i.into_pyobject(py)?.into_any());
    }
    if let Ok(f) = text.parse::<f64>() {
        return Ok(f.into_pyobject(py)?.into_any());
    }
    Ok(text.into_pyobject(py)?.into_any())
}

/// An image as a float32 array H x W x 3. The array takes over a buffer of the image's
/// floats (numpy frees it); the only copy is the one from `Image`'s RGB triples into it.
fn image_array<'py>(py: Python<'py>, image: &Image) -> PyResult<Bound<'py, PyAny>> {
    let floats: Vec<f32> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    let flat = PyArray1::from_vec(py, floats);
    Ok(flat
        .reshape([image.height as usize, image.width as usize, 3])?
        .into_any())
}

/// An H x W x 3 array as an image.
fn array_image(name: &str, a: &PyReadonlyArray3<'_, f32>) -> PyResult<Image> {
    let shape = a.shape();
    if shape[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array H x W x 3, got {shape:?}"
        )));
    }
    let pixels = a
        .as_array()
        .rows()
        .into_iter()
        .map(|rgb| lodestar::math::Spectrum::new(rgb[0], rgb[1], rgb[2]))
        .collect();
    Ok(Image {
        width: shape[1] as u32,
        height: shape[0] as u32,
        pixels,
    })
}

#[allow(clippy::too_many_arguments)]
#[pyfunction(name = "render")]
#[pyo3(signature = (scene, is_text, integrator, spp, time, seed, threads, max_depth, options, defines, progress))]
fn py_render<'py>(
    py: Python<'py>,
    scene: Option<String>,
    is_text: bool,
    integrator: Option<String>,
    spp: Option<u64>,
    time: Option<f64>,
    seed: u64,
    threads: Option<usize>,
    max_depth: Option<u32>,
    options: Vec<String>,
    defines: Vec<(String, String)>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    if spp.is_some() && time.is_some() {
        return Err(PyValueError::new_err("give spp or time, not both"));
    }
    if spp == Some(0) {
        return Err(PyValueError::new_err("spp must be at least 1"));
    }
    if let Some(t) = time
        && !(t.is_finite() && t > 0.0)
    {
        return Err(PyValueError::new_err(format!(
            "time must be a positive number of seconds, got {t}"
        )));
    }
    if threads == Some(0) {
        return Err(PyValueError::new_err("threads must be at least 1"));
    }
    if max_depth == Some(0) {
        return Err(PyValueError::new_err("max_depth must be at least 1"));
    }
    let scene = load_scene(scene.as_deref(), is_text, &defines)?;
    let name = integrator.unwrap_or_else(|| scene.render.integrator.clone());
    let params = IntegratorParams {
        max_depth: max_depth.unwrap_or(scene.render.max_depth),
        options: Options::parse(&options).map_err(err)?,
    };
    let budget = match (spp, time) {
        (_, Some(t)) => Budget::Seconds(t),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(scene.render.spp as u64),
    };
    let threads =
        threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let control = Control::default();
    let run = RunSettings {
        seed,
        threads,
        progress: false,
        snapshots: None,
        dbor: false,
        first_pass: 0,
        control: Some(&control),
        clock: None,
    };
    let (scene_ref, name_ref, run_ref) = (&scene, name.as_str(), &run);
    let named = run_controlled(py, &control, progress.as_ref(), move || {
        lodestar::integrators::render_named_with(scene_ref, name_ref, &params, budget, run_ref)
    })?
    .map_err(err)?;
    let r = &named.result;
    let stats = PyDict::new(py);
    stats.set_item("integrator", named.name)?;
    stats.set_item("settings", &named.settings)?;
    stats.set_item("spp", r.spp)?;
    stats.set_item("passes", r.passes)?;
    stats.set_item("seconds", r.seconds)?;
    stats.set_item("cpu_seconds", named.cpu_seconds)?;
    stats.set_item("seed", seed)?;
    stats.set_item("threads", threads)?;
    stats.set_item("scene", &scene.source)?;
    for (k, v) in &r.stats {
        stats.set_item(k, stat_value(py, v)?)?;
    }
    Ok((image_array(py, &r.image)?, stats))
}

#[allow(clippy::too_many_arguments)]
#[pyfunction(name = "bench")]
#[pyo3(signature = (scene, integrators, time, reference, runs, seed, threads, max_depth, defines, out, progress))]
fn py_bench<'py>(
    py: Python<'py>,
    scene: PathBuf,
    integrators: Vec<String>,
    time: f64,
    reference: PathBuf,
    runs: u32,
    seed: u64,
    threads: usize,
    max_depth: Option<u32>,
    defines: Vec<(String, String)>,
    out: PathBuf,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let config = BenchConfig {
        scene,
        defines,
        integrators,
        seconds: time,
        reference,
        runs,
        seed,
        out,
        threads,
        max_depth,
        crop: None,
        exposure: 0.0,
        verbose: false,
        splat_film: false,
    };
    let prepared = lodestar::bench::prepare(config).map_err(err)?;
    // Progress is the fraction of renders done; Ctrl-C ends the bench after the render
    // under way.
    let control = Control::default();
    let control_ref = &control;
    let report = run_controlled(py, &control, progress.as_ref(), move || {
        lodestar::bench::bench_controlled(&prepared, Some(control_ref))
    })?
    .map_err(err)?;
    let rows = PyList::empty(py);
    let mut all = report::run_rows(&report.results);
    all.extend(report::median_rows(&report.results));
    for row in all {
        let d = PyDict::new(py);
        d.set_item("integrator", &row.integrator)?;
        d.set_item("run", row.run)?;
        d.set_item("median", row.run.is_none())?;
        d.set_item("seed", row.seed)?;
        d.set_item("runs", row.runs)?;
        d.set_item("seconds", row.seconds)?;
        d.set_item("spp", row.spp)?;
        d.set_item("passes", row.passes)?;
        d.set_item("mse", row.mse)?;
        d.set_item("rmse", row.rmse)?;
        d.set_item("rel_mse", row.rel_mse)?;
        d.set_item("speedup", row.speedup)?;
        d.set_item("variance", row.variance)?;
        d.set_item("var_speedup", row.var_speedup)?;
        rows.append(d)?;
    }
    Ok(rows)
}

#[pyfunction(name = "compare")]
fn py_compare<'py>(
    py: Python<'py>,
    image: PyReadonlyArray3<'py, f32>,
    reference: PyReadonlyArray3<'py, f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let a = array_image("image", &image)?;
    let r = array_image("reference", &reference)?;
    let c = lodestar::metrics::compare(&a, &r).map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("mse", c.mse)?;
    d.set_item("rmse", c.rmse)?;
    d.set_item("rel_mse", c.rel_mse)?;
    d.set_item("mean", c.mean_a.to_array())?;
    d.set_item("mean_reference", c.mean_b.to_array())?;
    Ok(d)
}

#[pyfunction(name = "integrators")]
fn py_integrators<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for e in lodestar::integrators::entries() {
        let d = PyDict::new(py);
        d.set_item("name", e.name)?;
        d.set_item("summary", e.summary)?;
        let options = PyList::empty(py);
        for spec in lodestar::integrators::option_docs::options(&e) {
            let o = PyDict::new(py);
            o.set_item("name", spec.name)?;
            o.set_item("type", spec.kind.column())?;
            o.set_item("default", spec.default.column())?;
            o.set_item("meaning", spec.doc)?;
            options.append(o)?;
        }
        d.set_item("options", options)?;
        list.append(d)?;
    }
    Ok(list)
}

#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let (image, _) = Image::read_exr(&path).map_err(err)?;
    image_array(py, &image)
}

#[pyfunction]
fn write_exr(path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    array_image("image", &image)?
        .write_exr(&path, &[])
        .map_err(err)
}

#[pymodule]
fn _lodestar(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_render, m)?)?;
    m.add_function(wrap_pyfunction!(py_bench, m)?)?;
    m.add_function(wrap_pyfunction!(py_compare, m)?)?;
    m.add_function(wrap_pyfunction!(py_integrators, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    Ok(())
}
