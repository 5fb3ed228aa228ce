//! [`export_fmi3!`](crate::export_fmi3): the FMI 3.0 co-simulation C API (all 75 functions of
//! `fmi3Functions.h`, which importers such as FMPy bind when they load the library), each a
//! thin call into this crate — the same instance, state machine and values as FMI 2.0.

/// Defines the FMI 3.0 C API for `$model` (a [`Model`](crate::Model)) in the invoking crate,
/// which must be a `cdylib`; its model description is
/// [`model_description3`](crate::model_description3). A library may export FMI 2.0
/// ([`export_fmi2!`](crate::export_fmi2)) and FMI 3.0 both: the model description packed with
/// it decides which one an importer calls.
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        mod fmi3_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::*;
            use std::ffi::{c_char, c_void};
            use $crate::{Access, Kind, LogMessage3, Scalar, Status};
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> *const c_char {
                $crate::version3()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetDebugLogging(
                c: *mut c_void,
                on: bool,
                _n: usize,
                _categories: *const *const c_char,
            ) -> Status {
                unsafe { $crate::set_debug_logging::<M>(c, i32::from(on)) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
                name: *const c_char,
                token: *const c_char,
                _resources: *const c_char,
                _visible: bool,
                logging_on: bool,
                event_mode_used: bool,
                _early_return_allowed: bool,
                _required: *const u32,
                _n_required: usize,
                env: *mut c_void,
                log: Option<LogMessage3>,
                _intermediate_update: *const c_void,
            ) -> *mut c_void {
                unsafe {
                    $crate::instantiate3::<M>(name, token, logging_on, event_mode_used, env, log)
                }
            }
            #[no_mangle]
            pub extern "C" fn fmi3InstantiateModelExchange() -> *mut c_void {
                std::ptr::null_mut()
            }
            #[no_mangle]
            pub extern "C" fn fmi3InstantiateScheduledExecution() -> *mut c_void {
                std::ptr::null_mut()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeInstance(c: *mut c_void) {
                unsafe { $crate::free_instance::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterInitializationMode(
                c: *mut c_void,
                _tolerance_defined: bool,
                _tolerance: f64,
                start: f64,
                _stop_defined: bool,
                _stop: f64,
            ) -> Status {
                unsafe { $crate::enter_initialization_mode3::<M>(c, start) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitInitializationMode(c: *mut c_void) -> Status {
                unsafe { $crate::exit_initialization_mode::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Terminate(c: *mut c_void) -> Status {
                unsafe { $crate::terminate::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Reset(c: *mut c_void) -> Status {
                unsafe { $crate::reset::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DoStep(
                c: *mut c_void,
                time: f64,
                step: f64,
                _no_set_prior: bool,
                event: *mut bool,
                terminate: *mut bool,
                early: *mut bool,
                last: *mut f64,
            ) -> Status {
                unsafe { $crate::do_step3::<M>(c, time, step, event, terminate, early, last) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFMUState(
                c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::get_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFMUState(c: *mut c_void, state: *mut c_void) -> Status {
                unsafe { $crate::set_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeFMUState(
                _c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::free_state::<M>(state) }
            }
            $crate::__fmi3_values!(fmi3GetFloat64, fmi3SetFloat64, f64, Real,
                Scalar::Real, |s: Scalar| s.as_f64());
            $crate::__fmi3_values!(fmi3GetInt32, fmi3SetInt32, i32, Integer,
                Scalar::Integer, |s: Scalar| match s {
                    Scalar::Integer(i) => i,
                    other => other.as_f64() as i32,
                });
            $crate::__fmi3_values!(fmi3GetBoolean, fmi3SetBoolean, bool, Boolean,
                Scalar::Boolean, |s: Scalar| s.as_f64() != 0.0);
            $crate::__fmi3_none!(fmi3GetFloat32, fmi3SetFloat32, "Float32");
            $crate::__fmi3_none!(fmi3GetInt8, fmi3SetInt8, "Int8");
            $crate::__fmi3_none!(fmi3GetUInt8, fmi3SetUInt8, "UInt8");
            $crate::__fmi3_none!(fmi3GetInt16, fmi3SetInt16, "Int16");
            $crate::__fmi3_none!(fmi3GetUInt16, fmi3SetUInt16, "UInt16");
            $crate::__fmi3_none!(fmi3GetUInt32, fmi3SetUInt32, "UInt32");
            $crate::__fmi3_none!(fmi3GetInt64, fmi3SetInt64, "Int64");
            $crate::__fmi3_none!(fmi3GetUInt64, fmi3SetUInt64, "UInt64");
            $crate::__fmi3_none!(fmi3GetString, fmi3SetString, "String");
            $crate::__fmi3_unsupported!("this FMU has no Binary or Clock variables":
                fmi3GetBinary, fmi3SetBinary, fmi3GetClock, fmi3SetClock,
                fmi3GetIntervalDecimal, fmi3GetIntervalFraction, fmi3GetShiftDecimal,
                fmi3GetShiftFraction, fmi3SetIntervalDecimal, fmi3SetIntervalFraction,
                fmi3SetShiftDecimal, fmi3SetShiftFraction, fmi3ActivateModelPartition);
            $crate::__fmi3_unsupported!("hasEventMode is false":
                fmi3EnterEventMode, fmi3EnterStepMode, fmi3UpdateDiscreteStates,
                fmi3EvaluateDiscreteStates);
            $crate::__fmi3_unsupported!("this FMU has no structural parameters":
                fmi3EnterConfigurationMode, fmi3ExitConfigurationMode);
            $crate::__fmi3_unsupported!("canSerializeFMUState is false":
                fmi3SerializedFMUStateSize, fmi3SerializeFMUState, fmi3DeserializeFMUState);
            $crate::__fmi3_unsupported!("this FMU provides no derivatives or dependencies":
                fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative,
                fmi3GetOutputDerivatives, fmi3GetNumberOfVariableDependencies,
                fmi3GetVariableDependencies);
            $crate::__fmi3_unsupported!("this FMU is co-simulation only (no model exchange)":
                fmi3EnterContinuousTimeMode, fmi3CompletedIntegratorStep, fmi3SetTime,
                fmi3SetContinuousStates, fmi3GetContinuousStateDerivatives,
                fmi3GetEventIndicators, fmi3GetContinuousStates,
                fmi3GetNominalsOfContinuousStates, fmi3GetNumberOfEventIndicators,
                fmi3GetNumberOfContinuousStates);
        }
    };
}

/// `fmi3Get<T>` and `fmi3Set<T>` of a kind the model has (inside [`export_fmi3!`]).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_values {
    ($get:ident, $set:ident, $t:ty, $kind:ident, $into:expr, $out:expr) => {
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            c: *mut c_void,
            vr: *const u32,
            n: usize,
            v: *mut $t,
            n_values: usize,
        ) -> Status {
            let access = Access {
                kind: Kind::$kind,
                set: false,
            };
            unsafe { $crate::get_set3::<M, $t>(c, vr, n, v, n_values, access, $into, $out) }
        }
        #[no_mangle]
        pub unsafe extern "C" fn $set(
            c: *mut c_void,
            vr: *const u32,
            n: usize,
            v: *const $t,
            n_values: usize,
        ) -> Status {
            let access = Access {
                kind: Kind::$kind,
                set: true,
            };
            unsafe {
                $crate::get_set3::<M, $t>(c, vr, n, v as *mut $t, n_values, access, $into, $out)
            }
        }
    };
}

/// `fmi3Get<T>` and `fmi3Set<T>` of a type the model has no variables of (inside
/// [`export_fmi3!`]): nothing to do for no references, an error for any.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_none {
    ($get:ident, $set:ident, $what:literal) => {
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            c: *mut c_void,
            _vr: *const u32,
            n: usize,
            _v: *mut c_void,
            _n_values: usize,
        ) -> Status {
            unsafe { $crate::no_variables::<M>(c, n, stringify!($get), $what) }
        }
        #[no_mangle]
        pub unsafe extern "C" fn $set(
            c: *mut c_void,
            _vr: *const u32,
            n: usize,
            _v: *const c_void,
            _n_values: usize,
        ) -> Status {
            unsafe { $crate::no_variables::<M>(c, n, stringify!($set), $what) }
        }
    };
}

/// FMI 3.0 functions of capabilities this FMU declares false (inside [`export_fmi3!`]): each
/// logs why and returns `fmi3Error`. An importer that reads the model description never calls
/// them; they exist because importers bind every function when they load the library. Defined
/// with the instance argument only (C callers clean up their own arguments).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_unsupported {
    ($why:literal: $($name:ident),+ $(,)?) => {
        $(
            #[no_mangle]
            pub unsafe extern "C" fn $name(c: *mut c_void) -> Status {
                unsafe { $crate::unsupported::<M>(c, stringify!($name), $why) }
            }
        )+
    };
}
