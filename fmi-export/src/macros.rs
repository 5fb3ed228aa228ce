//! [`export_fmi2!`](crate::export_fmi2): the 34 `extern "C"` functions of the FMI 2.0
//! co-simulation API, each a thin call into this crate.

/// Defines the FMI 2.0 co-simulation C API for `$model` (a [`Model`](crate::Model)) in the
/// invoking crate, which must be a `cdylib`.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        mod fmi2_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc)]
            use super::*;
            use std::ffi::{c_char, c_void};
            use $crate::{Access, CallbackFunctions, Kind, Scalar, Status};
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                $crate::types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                $crate::version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: *mut c_void,
                on: i32,
                _n: usize,
                _categories: *const *const c_char,
            ) -> Status {
                unsafe { $crate::set_debug_logging::<M>(c, on) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: *const c_char,
                fmu_type: i32,
                guid: *const c_char,
                _resources: *const c_char,
                functions: *const CallbackFunctions,
                _visible: i32,
                logging_on: i32,
            ) -> *mut c_void {
                unsafe { $crate::instantiate::<M>(name, fmu_type, guid, functions, logging_on) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: *mut c_void) {
                unsafe { $crate::free_instance::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: *mut c_void,
                _tolerance_defined: i32,
                _tolerance: f64,
                start: f64,
                _stop_defined: i32,
                _stop: f64,
            ) -> Status {
                unsafe { $crate::setup_experiment::<M>(c, start) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: *mut c_void) -> Status {
                unsafe { $crate::enter_initialization_mode::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: *mut c_void) -> Status {
                unsafe { $crate::exit_initialization_mode::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: *mut c_void) -> Status {
                unsafe { $crate::terminate::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: *mut c_void) -> Status {
                unsafe { $crate::reset::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, f64>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Real,
                            set: false,
                        },
                        Scalar::Real,
                        |s| s.as_f64(),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Integer,
                            set: false,
                        },
                        Scalar::Integer,
                        |s| match s {
                            Scalar::Integer(i) => i,
                            other => other.as_f64() as i32,
                        },
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Boolean,
                            set: false,
                        },
                        |b| Scalar::Boolean(b != 0),
                        |s| i32::from(s.as_f64() != 0.0),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: *mut c_void,
                _vr: *const u32,
                n: usize,
                _v: *mut *const c_char,
            ) -> Status {
                unsafe { $crate::strings::<M>(c, n, false) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const f64,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, f64>(
                        c,
                        vr,
                        n,
                        v as *mut f64,
                        Access {
                            kind: Kind::Real,
                            set: true,
                        },
                        Scalar::Real,
                        |s| s.as_f64(),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v as *mut i32,
                        Access {
                            kind: Kind::Integer,
                            set: true,
                        },
                        Scalar::Integer,
                        |s| s.as_f64() as i32,
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v as *mut i32,
                        Access {
                            kind: Kind::Boolean,
                            set: true,
                        },
                        |b| Scalar::Boolean(b != 0),
                        |s| i32::from(s.as_f64() != 0.0),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: *mut c_void,
                _vr: *const u32,
                n: usize,
                _v: *const *const c_char,
            ) -> Status {
                unsafe { $crate::strings::<M>(c, n, true) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::get_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: *mut c_void, state: *mut c_void) -> Status {
                unsafe { $crate::set_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                _c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::free_state::<M>(state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: *mut c_void,
                _state: *mut c_void,
                _size: *mut usize,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SerializedFMUstateSize",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: *mut c_void,
                _state: *mut c_void,
                _bytes: *mut c_char,
                _size: usize,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SerializeFMUstate",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: *mut c_void,
                _bytes: *const c_char,
                _size: usize,
                _state: *mut *mut c_void,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2DeSerializeFMUstate",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: *mut c_void,
                _unknown: *const u32,
                _n_unknown: usize,
                _known: *const u32,
                _n_known: usize,
                _dv_known: *const f64,
                _dv_unknown: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetDirectionalDerivative",
                        "providesDirectionalDerivative is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: *mut c_void,
                _vr: *const u32,
                _n: usize,
                _order: *const i32,
                _v: *const f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SetRealInputDerivatives",
                        "canInterpolateInputs is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: *mut c_void,
                _vr: *const u32,
                _n: usize,
                _order: *const i32,
                _v: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetRealOutputDerivatives",
                        "maxOutputDerivativeOrder is 0",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: *mut c_void,
                time: f64,
                step: f64,
                _no_set_prior: i32,
            ) -> Status {
                unsafe { $crate::do_step::<M>(c, time, step) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: *mut c_void) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2CancelStep",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut Status,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetStatus",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: *mut c_void,
                kind: i32,
                value: *mut f64,
            ) -> Status {
                unsafe { $crate::last_successful_time::<M>(c, kind, value) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetIntegerStatus",
                        "no integer status is defined",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: *mut c_void,
                kind: i32,
                value: *mut i32,
            ) -> Status {
                unsafe { $crate::terminated::<M>(c, kind, value) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut *const c_char,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetStringStatus",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
        }
    };
}
