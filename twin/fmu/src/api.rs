//! The 34 `fmi2*` functions of FMI 2.0 co-simulation (FMI 2.0.4 §2.1, §4.2), C ABI. Every entry
//! catches panics (fmi2Fatal) and logs each refusal through the host's logger before returning
//! fmi2Error; what this FMU does not support (derivatives, asynchronous steps) is refused the
//! same way. An FMU state (§2.1.8) is a `State` on the heap, owned by the host until freed.
#![allow(non_snake_case, non_camel_case_types, clippy::missing_safety_doc)]

use crate::instance::{Instance, Phase};
use crate::state::State;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

pub type fmi2Component = *mut c_void;
pub type fmi2Status = c_int;
pub type fmi2Boolean = c_int;
pub type fmi2String = *const c_char;
pub type fmi2ValueReference = u32;

pub const OK: fmi2Status = 0;
pub const ERROR: fmi2Status = 3;
pub const FATAL: fmi2Status = 4;
const CO_SIMULATION: c_int = 1;

pub type Logger =
    unsafe extern "C" fn(*mut c_void, fmi2String, fmi2Status, fmi2String, fmi2String, ...);

/// fmi2CallbackFunctions (§2.1.5).
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<Logger>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, fmi2Status)>,
    pub component_environment: *mut c_void,
}

/// The host's logger and the instance's name, to say why a call was refused.
struct Host {
    logger: Option<Logger>,
    environment: *mut c_void,
    name: CString,
}

impl Host {
    fn log(&self, status: fmi2Status, message: &str) {
        let Some(logger) = self.logger else { return };
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let category = if status == OK {
            c"logStatusOK"
        } else {
            c"logStatusError"
        };
        // The message is a printf format: pass the text through "%s".
        unsafe {
            logger(
                self.environment,
                self.name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            )
        };
    }
}

struct Component {
    host: Host,
    instance: Instance,
    /// A call panicked: the instance's state is unknown, every later call is fmi2Fatal.
    broken: bool,
}

fn text(s: fmi2String) -> Option<String> {
    (!s.is_null()).then(|| unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

/// Runs `call` on the component: its refusal logged as fmi2Error, a panic as fmi2Fatal.
fn with(c: fmi2Component, call: impl FnOnce(&mut Instance) -> Result<(), String>) -> fmi2Status {
    if c.is_null() {
        return ERROR;
    }
    let component = unsafe { &mut *(c as *mut Component) };
    if component.broken {
        component
            .host
            .log(FATAL, "an earlier call failed inside; free this instance");
        return FATAL;
    }
    let instance = &mut component.instance;
    match catch_unwind(AssertUnwindSafe(|| call(instance))) {
        Ok(Ok(())) => OK,
        Ok(Err(reason)) => {
            component.host.log(ERROR, &reason);
            ERROR
        }
        Err(_) => {
            component
                .host
                .log(FATAL, "internal error (a panic); the instance is unusable");
            FATAL
        }
    }
}

/// `call` for each of `n` value references with its value slot.
fn each<T>(
    vr: *const fmi2ValueReference,
    n: usize,
    values: *mut T,
    mut call: impl FnMut(u32, &mut T) -> Result<(), String>,
) -> Result<(), String> {
    if n == 0 {
        return Ok(());
    }
    if vr.is_null() || values.is_null() {
        return Err("null value reference or value array".into());
    }
    let refs = unsafe { std::slice::from_raw_parts(vr, n) };
    let slots = unsafe { std::slice::from_raw_parts_mut(values, n) };
    refs.iter()
        .zip(slots)
        .try_for_each(|(&r, slot)| call(r, slot))
}

fn refuse(what: &str) -> Result<(), String> {
    Err(format!("{what} is not supported by this FMU"))
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> fmi2String {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> fmi2String {
    c"2.0".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    _on: fmi2Boolean,
    _n: usize,
    _categories: *const fmi2String,
) -> fmi2Status {
    with(c, |_| Ok(()))
}

/// fmi2Instantiate: the scenario in resources/ as a plant; the GUID must be this FMU's.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    name: fmi2String,
    kind: c_int,
    guid: fmi2String,
    resources: fmi2String,
    functions: *const CallbackFunctions,
    _visible: fmi2Boolean,
    _logging_on: fmi2Boolean,
) -> fmi2Component {
    let made = catch_unwind(|| {
        let callbacks = unsafe { functions.as_ref() };
        let host = Host {
            logger: callbacks.and_then(|f| f.logger),
            environment: callbacks.map_or(std::ptr::null_mut(), |f| f.component_environment),
            name: CString::new(text(name).unwrap_or_default()).unwrap_or_default(),
        };
        let instance = if kind != CO_SIMULATION {
            Err("this FMU supports co-simulation only (fmuType fmi2CoSimulation)".to_string())
        } else {
            let guid = text(guid).unwrap_or_default();
            let resources = text(resources).ok_or("no resourceLocation given".to_string());
            resources.and_then(|r| Instance::new(&r, &guid))
        };
        match instance {
            Ok(instance) => Box::into_raw(Box::new(Component {
                host,
                instance,
                broken: false,
            })) as fmi2Component,
            Err(reason) => {
                host.log(ERROR, &reason);
                std::ptr::null_mut()
            }
        }
    });
    made.unwrap_or(std::ptr::null_mut())
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    if !c.is_null() {
        let _ = catch_unwind(|| drop(unsafe { Box::from_raw(c as *mut Component) }));
    }
}

/// Only a start at t = 0 (the scenario's start); a tolerance and a stop time are not used.
#[no_mangle]
pub extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _tolerance_defined: fmi2Boolean,
    _tolerance: f64,
    start: f64,
    _stop_defined: fmi2Boolean,
    _stop: f64,
) -> fmi2Status {
    with(c, |_| match start {
        0.0 => Ok(()),
        _ => Err(format!(
            "startTime {start} s: the scenario starts at 0 s; use 0"
        )),
    })
}

#[no_mangle]
pub extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    with(c, |i| {
        i.phase = Phase::Initializing;
        Ok(())
    })
}

/// The plant at t = 0 with the seed set.
#[no_mangle]
pub extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    with(c, |i| {
        i.restart()?;
        i.phase = Phase::Stepping;
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    with(c, |i| {
        i.phase = Phase::Terminated;
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    with(c, Instance::reset)
}

#[no_mangle]
pub extern "C" fn fmi2GetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *mut f64,
) -> fmi2Status {
    with(c, |i| {
        each(vr, n, values, |r, v| {
            *v = i.get_real(r)?;
            Ok(())
        })
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *mut c_int,
) -> fmi2Status {
    with(c, |i| {
        each(vr, n, values, |r, v| {
            *v = i.get_integer(r)?;
            Ok(())
        })
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *mut fmi2Boolean,
) -> fmi2Status {
    with(c, |_| {
        each(vr, n, values, |r, _| {
            Err(format!("no Boolean variable has value reference {r}"))
        })
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *mut fmi2String,
) -> fmi2Status {
    with(c, |_| {
        each(vr, n, values, |r, _| {
            Err(format!("no String variable has value reference {r}"))
        })
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *const f64,
) -> fmi2Status {
    with(c, |i| {
        each(vr, n, values.cast_mut(), |r, v| i.set_real(r, *v))
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *const c_int,
) -> fmi2Status {
    with(c, |i| {
        each(vr, n, values.cast_mut(), |r, v| i.set_integer(r, *v))
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *const fmi2Boolean,
) -> fmi2Status {
    with(c, |_| {
        each(vr, n, values.cast_mut(), |r, _| {
            Err(format!("no Boolean variable has value reference {r}"))
        })
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    values: *const fmi2String,
) -> fmi2Status {
    with(c, |_| {
        each(vr, n, values.cast_mut(), |r, _| {
            Err(format!("no String variable has value reference {r}"))
        })
    })
}

/// The state behind a host's pointer, or why there is none.
fn state_at<'a>(state: *mut c_void) -> Result<&'a State, String> {
    (unsafe { (state as *const State).as_ref() }).ok_or_else(|| "null FMU state".to_string())
}

/// Hands `state` to the host at `slot`, over the state already there (FMI 2.0.4 §2.1.8: a
/// non-null `*slot` is overwritten).
fn give(slot: *mut *mut c_void, state: State) -> Result<(), String> {
    if slot.is_null() {
        return Err("null FMUstate pointer".into());
    }
    let slot = unsafe { &mut *slot };
    match unsafe { (*slot as *mut State).as_mut() } {
        Some(existing) => *existing = state,
        None => *slot = Box::into_raw(Box::new(state)) as *mut c_void,
    }
    Ok(())
}

/// fmi2GetFMUstate: the parameters, seed, inputs and every period's inputs so far.
#[no_mangle]
pub extern "C" fn fmi2GetFMUstate(c: fmi2Component, state: *mut *mut c_void) -> fmi2Status {
    with(c, |i| give(state, i.state()))
}

/// fmi2SetFMUstate: the state's periods replayed from t = 0 (exact; the twin is deterministic).
#[no_mangle]
pub extern "C" fn fmi2SetFMUstate(c: fmi2Component, state: *mut c_void) -> fmi2Status {
    with(c, |i| i.set_state(state_at(state)?))
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: fmi2Component, state: *mut *mut c_void) -> fmi2Status {
    with(c, |_| {
        if !state.is_null() {
            let slot = unsafe { &mut *state };
            if !slot.is_null() {
                drop(unsafe { Box::from_raw(*slot as *mut State) });
                *slot = std::ptr::null_mut();
            }
        }
        Ok(())
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    state: *mut c_void,
    size: *mut usize,
) -> fmi2Status {
    with(c, |_| {
        let bytes = state_at(state)?.to_bytes();
        let size = unsafe { size.as_mut() }.ok_or("null size pointer")?;
        *size = bytes.len();
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    state: *mut c_void,
    bytes: *mut c_char,
    size: usize,
) -> fmi2Status {
    with(c, |_| {
        let serialized = state_at(state)?.to_bytes();
        if serialized.len() != size || bytes.is_null() {
            return Err(format!(
                "the serialized FMU state is {} bytes, not {size}: ask fmi2SerializedFMUstateSize",
                serialized.len()
            ));
        }
        let out = unsafe { std::slice::from_raw_parts_mut(bytes as *mut u8, size) };
        out.copy_from_slice(&serialized);
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    bytes: *const c_char,
    size: usize,
    state: *mut *mut c_void,
) -> fmi2Status {
    with(c, |_| {
        if bytes.is_null() {
            return Err("null serialized FMU state".into());
        }
        let serialized = unsafe { std::slice::from_raw_parts(bytes as *const u8, size) };
        give(state, State::from_bytes(serialized)?)
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    _unknowns: *const fmi2ValueReference,
    _n_unknowns: usize,
    _knowns: *const fmi2ValueReference,
    _n_knowns: usize,
    _seed: *const f64,
    _derivative: *mut f64,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetDirectionalDerivative (providesDirectionalDerivative = false)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const c_int,
    _values: *const f64,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2SetRealInputDerivatives (canInterpolateInputs = false)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const c_int,
    _values: *mut f64,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder = 0)")
    })
}

/// fmi2DoStep: whole control periods from the current time, efforts held.
#[no_mangle]
pub extern "C" fn fmi2DoStep(
    c: fmi2Component,
    time: f64,
    size: f64,
    _no_set_prior_state: fmi2Boolean,
) -> fmi2Status {
    with(c, |i| i.do_step(time, size))
}

#[no_mangle]
pub extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2CancelStep (fmi2DoStep never returns fmi2Pending)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetStatus(c: fmi2Component, _kind: c_int, _value: *mut c_int) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetStatus (fmi2DoStep never returns fmi2Pending)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetRealStatus(
    c: fmi2Component,
    _kind: c_int,
    _value: *mut f64,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetRealStatus (fmi2DoStep never returns fmi2Pending)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    _kind: c_int,
    _value: *mut c_int,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetIntegerStatus (fmi2DoStep never returns fmi2Pending)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetBooleanStatus(
    c: fmi2Component,
    _kind: c_int,
    _value: *mut fmi2Boolean,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetBooleanStatus (fmi2DoStep never returns fmi2Pending)")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    _kind: c_int,
    _value: *mut fmi2String,
) -> fmi2Status {
    with(c, |_| {
        refuse("fmi2GetStringStatus (fmi2DoStep never returns fmi2Pending)")
    })
}
