//! The one error type of the host. Every variant names the thing at fault and, where the user can
//! fix it, how.

use ash::vk;
use std::path::PathBuf;

/// Everything that can go wrong between the program and the Vulkan device.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The Vulkan loader library could not be opened.
    #[error(
        "no Vulkan loader (libvulkan.so.1): {0}; install it with scripts/setup.sh (Debian package libvulkan1)"
    )]
    NoLoader(String),
    /// The loader works but lists no usable device.
    #[error(
        "no Vulkan device found{0}; install lavapipe (Mesa >= 25, ray queries) with scripts/setup.sh"
    )]
    NoDevice(String),
    /// The device the user asked for does not exist.
    #[error("no Vulkan device matches --device {wanted:?}; available: {available}")]
    DeviceNotFound {
        /// What the user asked for.
        wanted: String,
        /// The devices there are, with their indices.
        available: String,
    },
    /// The device lacks something the chosen kernels need.
    #[error("device {device:?} lacks {feature}, needed for {needed_for}")]
    MissingFeature {
        /// Device name.
        device: String,
        /// The Vulkan feature, extension or limit.
        feature: String,
        /// What needs it.
        needed_for: String,
    },
    /// Validation layers were requested but are not installed.
    #[error(
        "Vulkan validation layer VK_LAYER_KHRONOS_validation is not installed; run scripts/setup.sh (Debian package vulkan-validationlayers) or turn validation off"
    )]
    NoValidationLayer,
    /// A Vulkan call failed; a lost device, a submission taken for a hang and exhausted memory
    /// say what that means.
    #[error("Vulkan call {call} failed: {result}{}", meaning(*result))]
    Vulkan {
        /// The call that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },
    /// GPU memory for a resource could not be had: the device refused it, the allocator failed,
    /// or the request exceeds what the device can hold at all.
    #[error("GPU memory allocation of {what:?}{} failed: {why}", bytes.map(size).unwrap_or_default())]
    Allocation {
        /// The resource being allocated.
        what: String,
        /// Its size in bytes, where the failure is of one request.
        bytes: Option<u64>,
        /// Why it failed.
        why: String,
    },
    /// A kernel entry point does not exist in the compiled SPIR-V module.
    #[error("kernel entry point {0:?} is not in the {1} kernel module")]
    NoSuchKernel(String, &'static str),
    /// Arguments that make no sense.
    #[error("invalid argument {name}: {why}")]
    InvalidArgument {
        /// The argument at fault.
        name: &'static str,
        /// Why it is rejected.
        why: String,
    },
    /// A scene file that cannot be loaded: the file, the element at fault (a glTF path such as
    /// `meshes[2].primitives[0].indices`, or a file it references) and why.
    #[error("{}: {element}: {why}", file.display())]
    Scene {
        /// The scene file.
        file: PathBuf,
        /// The element at fault.
        element: String,
        /// What is wrong with it.
        why: String,
    },
    /// An output file (a report, a table, a plot) that cannot be written: the file and why.
    #[error("{}: {why}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        why: String,
    },
    /// An image file that cannot be read or written: the file and why.
    #[error("{}: {why}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong with it.
        why: String,
    },
}

/// What a result code means for the user, for the few that need saying.
fn meaning(result: vk::Result) -> &'static str {
    match result {
        vk::Result::ERROR_DEVICE_LOST => {
            " (the device was lost: a driver reset, a GPU fault or a kernel that ran too long; \
             nothing more is submitted to it, and the program must create a new context)"
        }
        vk::Result::TIMEOUT => {
            " (a submission ran past SUBMIT_TIMEOUT and is taken for a hang: the device is treated \
             as lost, nothing more is submitted to it)"
        }
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            " (out of memory: lower the resolution or the scene's size)"
        }
        _ => "",
    }
}

/// ` (N bytes, X GiB)`: a request's size as an allocation error gives it.
fn size(bytes: u64) -> String {
    format!(
        " ({bytes} bytes, {:.3} GiB)",
        bytes as f64 / f64::from(1 << 30)
    )
}

/// Result with the host's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Attaches the name of the Vulkan call to a raw `vk::Result`.
pub(crate) trait VkContext<T> {
    /// Maps the error to [`Error::Vulkan`] naming `call`.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What cannot be provoked on lavapipe (a lost or hung device) still reads as one line that
    /// says what happened and what follows.
    #[test]
    fn lost_and_hung_devices_explain_themselves() {
        let lost = Error::Vulkan {
            call: "vkWaitForFences",
            result: vk::Result::ERROR_DEVICE_LOST,
        }
        .to_string();
        let code = vk::Result::ERROR_DEVICE_LOST;
        assert!(
            lost.starts_with(&format!("Vulkan call vkWaitForFences failed: {code}")),
            "{lost}"
        );
        assert!(lost.contains("the device was lost") && lost.contains("new context"));
        let hung = Error::Vulkan {
            call: "vkWaitForFences",
            result: vk::Result::TIMEOUT,
        }
        .to_string();
        assert!(
            hung.contains("SUBMIT_TIMEOUT") && hung.contains("hang"),
            "{hung}"
        );
        let other = Error::Vulkan {
            call: "vkCreateFence",
            result: vk::Result::ERROR_INITIALIZATION_FAILED,
        }
        .to_string();
        assert_eq!(
            other,
            format!(
                "Vulkan call vkCreateFence failed: {}",
                vk::Result::ERROR_INITIALIZATION_FAILED
            )
        );
        for message in [lost, hung] {
            assert!(!message.contains('\n'), "{message}");
        }
    }

    #[test]
    fn allocation_errors_give_the_resource_and_its_size() {
        let e = Error::Allocation {
            what: "huge".into(),
            bytes: Some(1 << 40),
            why: "too big".into(),
        };
        assert_eq!(
            e.to_string(),
            "GPU memory allocation of \"huge\" (1099511627776 bytes, 1024.000 GiB) failed: too big"
        );
    }
}
