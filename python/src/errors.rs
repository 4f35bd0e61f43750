//! The exception classes of the `lincal` module and the conversion of `lincal_core` errors into
//! them.
//!
//! ```text
//! lincal.Error(Exception)                  every error lincal raises
//! ├── lincal.InputError(Error, ValueError) bad input (the CLI's exit status 2)
//! │   ├── lincal.SpecError                 in a spec (YAML file, text or dict)
//! │   └── lincal.DataError                 in the arrays (q, x, constraint, lines) or a CSV
//! ├── lincal.DegenerateError(Error, ValueError)  valid input that cannot be calibrated (exit 1)
//! ├── lincal.ComputationError(Error, RuntimeError) a bound crossed (`max_terms`), a numerical
//! │                                         failure, I/O (the rest of exit 1)
//! └── lincal.InternalError(Error, RuntimeError)  a bug: a panic caught at the boundary
//! ```
//! Every instance carries the place of its first problem as attributes (`file`, `line`,
//! `column`, `field`, `pose`, each `None` when unknown) and every problem in `diagnostics`
//! (a tuple of dicts with those keys and `message`).

use lincal_core::error::{Diagnostic, Error, ErrorClass};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

/// Which input an error is about, to choose between `SpecError`, `DataError` and
/// `InputError` for bad input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A spec read from a file or text: lines and columns are the user's.
    SpecText,
    /// A spec built from a Python dict: lines and columns belong to the text lincal made
    /// from it, so only the field path is reported.
    SpecDict,
    /// Readings (arrays or a CSV file).
    Data,
    /// Anything else: an option, a parameter vector.
    Other,
    /// A parameter mapping given as a dict (only the field path is reported).
    OtherDict,
}

/// Creates the exception classes and adds them to the module `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let type_ = py.import("builtins")?.getattr("type")?;
    fn make<'py>(
        m: &Bound<'py, PyModule>,
        type_: &Bound<'py, PyAny>,
        name: &str,
        bases: Vec<Bound<'py, PyAny>>,
        doc: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = m.py();
        let attrs = PyDict::new(py);
        attrs.set_item("__doc__", doc)?;
        attrs.set_item("__module__", "lincal")?;
        if name == "Error" {
            for key in ["file", "line", "column", "field", "pose"] {
                attrs.set_item(key, py.None())?;
            }
            attrs.set_item("diagnostics", PyTuple::empty(py))?;
        }
        let cls = type_.call1((name, PyTuple::new(py, bases)?, attrs))?;
        m.add(name, &cls)?;
        Ok(cls)
    }
    let exception = py.get_type::<pyo3::exceptions::PyException>().into_any();
    let value_error = py.get_type::<pyo3::exceptions::PyValueError>().into_any();
    let runtime_error = py.get_type::<pyo3::exceptions::PyRuntimeError>().into_any();
    let base = make(
        m,
        &type_,
        "Error",
        vec![exception],
        "Base of every lincal error. Attributes: `file`, `line`, `column` (1-based), `field` \
         (a field path such as `joints[1].home`, or a data column such as `q2`), `pose` \
         (0-based row) of the first problem, each None when unknown; `diagnostics`: every \
         problem, a tuple of dicts with those keys and `message`.",
    )?;
    let input = make(
        m,
        &type_,
        "InputError",
        vec![base.clone(), value_error.clone()],
        "Bad input (what the command line exits 2 for): a spec, array, file or option that is \
         wrong. A ValueError.",
    )?;
    make(
        m,
        &type_,
        "SpecError",
        vec![input.clone()],
        "A problem in a spec (YAML file, YAML text or dict), located by `field` (and by `line`, \
         `column` for YAML text).",
    )?;
    make(
        m,
        &type_,
        "DataError",
        vec![input],
        "A problem in the readings: an array of the wrong shape or dtype, a NaN or infinite \
         value, a constraint index out of range (`pose` is the 0-based row, `field` the column, \
         e.g. `q2`), or a bad CSV cell (`line`, `field`).",
    )?;
    make(
        m,
        &type_,
        "DegenerateError",
        vec![base.clone(), value_error],
        "Valid input that cannot be calibrated (what the command line exits 1 for): too few \
         poses, a frozen joint, lost rank, a constraint the arm cannot reach; the message says \
         what is lost. A ValueError.",
    )?;
    make(
        m,
        &type_,
        "ComputationError",
        vec![base.clone(), runtime_error.clone()],
        "Valid input whose computation cannot be done: an exact expansion beyond `max_terms`, \
         a numerical failure, an unreadable or unwritable file (the rest of what the command \
         line exits 1 for). A RuntimeError.",
    )?;
    make(
        m,
        &type_,
        "InternalError",
        vec![base, runtime_error],
        "A bug: a panic caught at the boundary (none is expected on any input). A RuntimeError.",
    )?;
    Ok(())
}

/// The exception class `name` of the `lincal` module.
fn class<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("lincal")?.getattr(name)
}

/// An exception of class `name` with `message`, located by `diagnostics` (attributes from
/// the first one).
fn raise(
    py: Python<'_>,
    name: &str,
    message: &str,
    diagnostics: &[Diagnostic],
    dict: bool,
) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let cls = class(py, name)?;
        let exc = cls.call1((message,))?;
        let mut all = Vec::with_capacity(diagnostics.len());
        for d in diagnostics {
            let item = PyDict::new(py);
            let l = &d.location;
            item.set_item("file", l.file.as_deref())?;
            item.set_item("line", if dict { None } else { l.line })?;
            item.set_item("column", if dict { None } else { l.column })?;
            item.set_item("field", l.field.as_deref())?;
            item.set_item("pose", l.pose)?;
            item.set_item("message", &d.message)?;
            all.push(item);
        }
        if let Some(first) = all.first() {
            for key in ["file", "line", "column", "field", "pose"] {
                exc.setattr(key, first.get_item(key)?)?;
            }
        }
        exc.setattr("diagnostics", PyTuple::new(py, all)?)?;
        Ok(PyErr::from_value(exc))
    };
    build().unwrap_or_else(|e| e)
}

/// A diagnostic as text; for a spec from a dict without the line and column of the text made
/// from it.
fn diagnostic_text(d: &Diagnostic, dict: bool) -> String {
    if !dict {
        return d.to_string();
    }
    let mut l = d.location.clone();
    l.line = None;
    l.column = None;
    Diagnostic {
        location: l,
        message: d.message.clone(),
    }
    .to_string()
}

/// A `lincal_core` error as the matching Python exception.
pub fn to_py(py: Python<'_>, e: &Error, origin: Origin) -> PyErr {
    let dict = matches!(origin, Origin::SpecDict | Origin::OtherDict);
    let name = match (e.class(), origin) {
        (ErrorClass::Input, Origin::SpecText | Origin::SpecDict) => "SpecError",
        (ErrorClass::Input, Origin::Data) => "DataError",
        (ErrorClass::Input, Origin::Other | Origin::OtherDict) => "InputError",
        (ErrorClass::Degenerate, _) => "DegenerateError",
        (ErrorClass::Other, _) => "ComputationError",
    };
    let message: Vec<String> = e
        .diagnostics()
        .iter()
        .map(|d| diagnostic_text(d, dict))
        .collect();
    raise(py, name, &message.join("\n"), e.diagnostics(), dict)
}

/// A `DataError` about the readings, at a field (column) and pose (row) when known.
pub fn data_error(
    py: Python<'_>,
    field: Option<&str>,
    pose: Option<usize>,
    message: &str,
) -> PyErr {
    let location = lincal_core::error::Location {
        field: field.map(str::to_string),
        pose,
        ..Default::default()
    };
    let d = Diagnostic {
        location,
        message: message.to_string(),
    };
    raise(py, "DataError", &d.to_string(), &[d], false)
}

/// An `InputError` about an argument (`field` names it).
pub fn input_error(py: Python<'_>, field: &str, message: &str) -> PyErr {
    let d = Diagnostic {
        location: lincal_core::error::Location {
            field: Some(field.to_string()),
            ..Default::default()
        },
        message: message.to_string(),
    };
    raise(py, "InputError", &d.to_string(), &[d], false)
}

/// `e` with the command line's option names (`--noise-encoder`, `-n`) as the keyword
/// arguments of the Python function (`noise_encoder`, `n`), in fields and messages: the core
/// names the options, a Python caller should read the arguments.
pub fn keyword_names(e: &Error) -> Error {
    let keyword = |s: &str| {
        s.replace("--noise-", "noise_")
            .replace("--max-off", "max_off")
            .replace("--candidates", "candidates")
            .replace("--pool", "pool")
            .replace("--given", "given")
            .replace("--draws", "draws")
            .replace("(-n)", "(n)")
    };
    let renamed = e
        .diagnostics()
        .iter()
        .cloned()
        .map(|mut d| {
            d.location.field = d.location.field.map(|f| {
                if f == "-n" {
                    "n".to_string()
                } else {
                    f.trim_start_matches("--").replace('-', "_")
                }
            });
            d.message = keyword(&d.message);
            d
        })
        .collect();
    Error::from_diagnostics(e.class(), renamed)
}

/// An `InternalError` for a panic caught at the boundary (none is expected on any input).
pub fn internal(py: Python<'_>, what: &str) -> PyErr {
    raise(
        py,
        "InternalError",
        &format!("internal error in {what} (a bug, please report it)"),
        &[],
        false,
    )
}

/// Runs `f`, turning a panic into `Err(())` so that no panic crosses into Python.
pub fn guarded<T>(f: impl FnOnce() -> T) -> Result<T, ()> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|_| ())
}

/// Runs `work` with the GIL released, on a worker thread, while this thread checks every
/// 100 ms for Python signals: on Ctrl-C (a `KeyboardInterrupt`, or whatever the signal
/// handler raises) the running computation is asked to stop ([`lincal_core::cancel`]; it
/// stops within one iteration of its fit) and the signal's exception is raised once it has.
/// A call that finishes first returns at once (the worker wakes this thread).
///
/// # Errors
/// The exception the signal handler raised.
pub fn interruptible<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| {
        std::thread::scope(|s| {
            let waiter = std::thread::current();
            let worker = std::thread::Builder::new()
                // The engine's recursion (expansion, reduction) is sized for a main thread.
                .stack_size(64 << 20)
                .spawn_scoped(s, move || {
                    let out = work();
                    waiter.unpark();
                    out
                });
            let worker = match worker {
                Ok(w) => w,
                Err(e) => {
                    return Err(PyErr::new::<pyo3::exceptions::PyMemoryError, _>(format!(
                        "cannot start the worker thread: {e}"
                    )))
                }
            };
            let mut signal: Option<PyErr> = None;
            while !worker.is_finished() {
                std::thread::park_timeout(std::time::Duration::from_millis(100));
                if signal.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        lincal_core::cancel::request();
                        signal = Some(e);
                    }
                }
            }
            let out = worker.join();
            if let Some(e) = signal {
                lincal_core::cancel::clear();
                return Err(e);
            }
            // The work is guarded: a panic is its own `Err`, never this one.
            out.map_err(|_| {
                PyErr::new::<pyo3::exceptions::PyRuntimeError, _>("the worker thread panicked")
            })
        })
    })
}

/// A `MemoryError` before the allocation when `bytes` (what `what` will need, estimated)
/// exceed the memory the process may still take, so that a huge input is refused with a
/// message instead of the allocator aborting the interpreter.
///
/// # Errors
/// The `MemoryError`.
pub fn check_memory(what: &str, bytes: u64) -> PyResult<()> {
    match lincal_core::memory::available() {
        Some(avail) if bytes > avail => {
            Err(PyErr::new::<pyo3::exceptions::PyMemoryError, _>(format!(
                "{what} needs about {:.1} GB and {:.1} GB are available: give fewer poses, \
                 or calibrate on a subset",
                bytes as f64 / 1e9,
                avail as f64 / 1e9
            )))
        }
        _ => Ok(()),
    }
}
