//! Reading and writing variable values by value reference: the bodies of `fmi2Get*` and
//! `fmi2Set*`, with their checks (known reference, matching kind, parameters settable only
//! before initialisation, outputs never).

use crate::ffi::Status;
use crate::instance::{instance, Instance, Phase};
use crate::model::{Causality, Kind, Model, Scalar};
use std::ffi::c_void;

/// Checks the value references and kinds of a get or set call.
fn check<M: Model>(
    i: &mut Instance<M>,
    call: &str,
    vr: &[u32],
    kind: Kind,
    set: bool,
) -> Result<(), Status> {
    let vars = M::variables();
    for &r in vr {
        let Some(v) = vars.get(r as usize) else {
            return Err(i.fail(call, &format!("unknown value reference {r}")));
        };
        if v.start.kind() != kind {
            return Err(i.fail(
                call,
                &format!("`{}` is {:?}, not {kind:?}", v.name, v.start.kind()),
            ));
        }
        if set {
            let allowed = v.causality == Causality::Parameter
                && matches!(i.phase, Phase::Instantiated | Phase::Initialization);
            if !allowed {
                return Err(i.fail(
                    call,
                    &format!(
                        "`{}` cannot be set now (parameters are set before fmi2ExitInitializationMode; outputs never)",
                        v.name
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A get or a set of one kind of value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Access {
    /// The kind of the values.
    pub kind: Kind,
    /// Set (true) or get.
    pub set: bool,
}

/// The body of the FMI 3.0 `fmi3Get*` / `fmi3Set*` functions (Float64, Int32, Boolean): FMI
/// 2.0's [`get_set`] after checking that there is one value per reference (`n_values`).
///
/// # Safety
/// As [`get_set`].
// The C function's five arguments plus the access and the two conversions of `get_set`.
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_set3<M: Model, T: Copy>(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut T,
    n_values: usize,
    access: Access,
    convert_in: impl Fn(T) -> Scalar,
    convert_out: impl Fn(Scalar) -> T,
) -> Status {
    if n_values != n {
        // SAFETY: see above.
        return match unsafe { instance::<M>(c) } {
            Some(i) => i.fail(
                "fmi2Get/Set",
                &format!("{n} value references but {n_values} values (this FMU has no arrays)"),
            ),
            None => Status::Error,
        };
    }
    // SAFETY: see above.
    unsafe { get_set::<M, T>(c, vr, n, values, access, convert_in, convert_out) }
}

/// Reads or writes `n` values of one kind: the body of the `fmi2Get*` / `fmi2Set*` functions.
///
/// # Safety
/// `vr` points to `n` value references and `values` to `n` values (FMI 2.0 standard).
pub unsafe fn get_set<M: Model, T: Copy>(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut T,
    access: Access,
    convert_in: impl Fn(T) -> Scalar,
    convert_out: impl Fn(Scalar) -> T,
) -> Status {
    let Access { kind, set } = access;
    let call = match (set, kind) {
        (false, Kind::Real) => "fmi2GetReal",
        (false, Kind::Integer) => "fmi2GetInteger",
        (false, Kind::Boolean) => "fmi2GetBoolean",
        (true, Kind::Real) => "fmi2SetReal",
        (true, Kind::Integer) => "fmi2SetInteger",
        (true, Kind::Boolean) => "fmi2SetBoolean",
    };
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if n == 0 {
        return Status::Ok;
    }
    if vr.is_null() || values.is_null() {
        return i.fail(call, "null array");
    }
    // SAFETY: n value references, by the caller's contract.
    let refs = unsafe { std::slice::from_raw_parts(vr, n) };
    if let Err(s) = check(i, call, refs, kind, set) {
        return s;
    }
    for (k, &r) in refs.iter().enumerate() {
        // SAFETY: n values, by the caller's contract.
        let slot = unsafe { values.add(k) };
        if set {
            // SAFETY: see above.
            let v = convert_in(unsafe { *slot });
            if let (Scalar::Real(x), Some(var)) = (v, M::variables().get(r as usize)) {
                if !x.is_finite() {
                    return i.fail(call, &format!("`{}` = {x} is not finite", var.name));
                }
            }
            i.values[r as usize] = v;
        } else {
            // SAFETY: see above.
            unsafe { *slot = convert_out(i.values[r as usize]) };
        }
    }
    Status::Ok
}

/// `fmi2GetString` / `fmi2SetString`: this FMU has no string variables.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
pub unsafe fn strings<M: Model>(c: *mut c_void, n: usize, set: bool) -> Status {
    no_variables::<M>(
        c,
        n,
        if set {
            "fmi2SetString"
        } else {
            "fmi2GetString"
        },
        "string",
    )
}

/// A get or set of a type this FMU has no variables of (`kind`: "string", "Float32", …):
/// nothing to do for no references, an error for any.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) or
/// [`instantiate3`](crate::instantiate3) for the same model and not yet freed.
pub unsafe fn no_variables<M: Model>(c: *mut c_void, n: usize, call: &str, kind: &str) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if n == 0 {
        return Status::Ok;
    }
    i.fail(call, &format!("this FMU has no {kind} variables"))
}
