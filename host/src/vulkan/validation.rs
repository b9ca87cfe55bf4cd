//! Collects the validation layer's warnings and errors so that tests can fail on any of them.

use ash::vk;
use std::ffi::{CStr, c_void};
use std::sync::Mutex;

/// Every validation warning and error, in order.
#[derive(Default)]
pub(crate) struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    pub(crate) fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

/// The debug-utils callback; `user_data` points at the context's [`ValidationLog`].
pub(crate) unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let text = unsafe { data.as_ref() }
        .and_then(|d| unsafe { d.message_as_c_str() })
        .map(CStr::to_string_lossy)
        .unwrap_or_default();
    let line = format!("vulkan {severity:?} {kind:?}: {text}");
    eprintln!("{line}");
    if let Some(log) = unsafe { user_data.cast::<ValidationLog>().as_ref() }
        && let Ok(mut m) = log.messages.lock()
    {
        m.push(line);
    }
    vk::FALSE
}
