//! The calls into Intel Open Image Denoise (feature `oidn`). The `oidn` crate wraps the generic
//! `RT` filter only, so the `RTLightmap` filter is made and set up through its raw bindings
//! (`oidn::sys`); the device and the buffer come from the crate's safe API. This is the only
//! `unsafe` code of vlf-core (the workspace denies it elsewhere): every call below is the C API
//! used as its documentation says, on handles checked for null and released by their owners.
#![allow(unsafe_code)]

use std::ffi::{CStr, c_char};
use std::ptr;

use oidn::sys;

use super::OidnError;

fn library(call: &'static str, e: oidn::Error) -> OidnError {
    OidnError::Library {
        call,
        message: e.to_string(),
    }
}

/// The error OIDN recorded for `device` (null: errors not tied to a device), if any.
fn device_error(device: sys::OIDNDevice) -> Option<String> {
    let mut msg: *const c_char = ptr::null();
    // SAFETY: `device` is null or a live device; OIDN writes a pointer to a NUL-terminated
    // string it owns (valid until the next call on this thread) or leaves it null.
    let code = unsafe { sys::oidnGetDeviceError(device, &mut msg) };
    if code == sys::OIDNError_OIDN_ERROR_NONE {
        return None;
    }
    Some(if msg.is_null() {
        format!("error code {code}")
    } else {
        // SAFETY: see above; copied before any further OIDN call.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    })
}

/// A filter handle, released when dropped.
struct Filter(sys::OIDNFilter);

impl Drop for Filter {
    fn drop(&mut self) {
        // SAFETY: a non-null handle from `oidnNewFilter`, released once.
        unsafe { sys::oidnReleaseFilter(self.0) };
    }
}

/// Filters `image` (`width` × `height` RGB f32 pixels, row-major) in place with OIDN's
/// `RTLightmap` filter on a CPU device of `threads` threads (0: OIDN's default).
pub(super) fn rt_lightmap(
    image: &mut [f32],
    width: usize,
    height: usize,
    threads: usize,
) -> Result<(), OidnError> {
    assert_eq!(
        image.len(),
        3 * width * height,
        "an RGB image of width × height"
    );
    // SAFETY: plain constructor; a null result is handled below.
    let raw = unsafe { sys::oidnNewDevice(sys::OIDNDeviceType_OIDN_DEVICE_TYPE_CPU) };
    if raw.is_null() {
        return Err(OidnError::Library {
            call: "oidnNewDevice(CPU)",
            message: device_error(ptr::null_mut())
                .unwrap_or_else(|| "no CPU device (is its module beside the library?)".into()),
        });
    }
    if threads > 0 {
        // SAFETY: a live, not yet committed device; a documented parameter.
        unsafe { sys::oidnSetDeviceInt(raw, c"numThreads".as_ptr(), threads.min(1 << 16) as i32) };
    }
    // SAFETY: a live device, committed once before use.
    unsafe { sys::oidnCommitDevice(raw) };
    // SAFETY: `raw` is live and committed; `Device` now owns it and releases it when dropped.
    let device = unsafe { oidn::Device::from_raw(raw) };
    device
        .get_error()
        .map_err(|e| library("oidnCommitDevice", e))?;
    let buffer = device
        .create_buffer(image)
        .map_err(|e| library("oidnNewBuffer", e))?;
    // SAFETY: a live device and a NUL-terminated filter type.
    let handle = unsafe { sys::oidnNewFilter(raw, c"RTLightmap".as_ptr()) };
    if handle.is_null() {
        return Err(OidnError::Library {
            call: "oidnNewFilter(RTLightmap)",
            message: device_error(raw).unwrap_or_else(|| "no such filter".into()),
        });
    }
    let filter = Filter(handle);
    // SAFETY: a live filter; the buffer holds 3 × width × height floats and outlives the
    // execution below (it is read back after it); input and output may be the same image.
    unsafe {
        for name in [c"color", c"output"] {
            sys::oidnSetFilterImage(
                filter.0,
                name.as_ptr(),
                buffer.raw(),
                sys::OIDNFormat_OIDN_FORMAT_FLOAT3,
                width,
                height,
                0,
                0,
                0,
            );
        }
        sys::oidnSetFilterBool(filter.0, c"directional".as_ptr(), false);
        sys::oidnCommitFilter(filter.0);
    }
    if let Some(message) = device_error(raw) {
        return Err(OidnError::Library {
            call: "oidnCommitFilter(RTLightmap)",
            message,
        });
    }
    // SAFETY: a committed filter whose images are live; synchronous.
    unsafe { sys::oidnExecuteFilter(filter.0) };
    if let Some(message) = device_error(raw) {
        return Err(OidnError::Library {
            call: "oidnExecuteFilter(RTLightmap)",
            message,
        });
    }
    drop(filter);
    buffer
        .read_to_slice(image)
        .map_err(|e| library("oidnReadBuffer", e))
}
