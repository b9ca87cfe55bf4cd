//! The Vulkan context: instance, validation, device selection, feature enabling, the compute queue,
//! the memory allocator and one-shot submissions.

use super::capabilities::{Capabilities, FeatureChain};
use super::memory::{BufferInfo, DeviceMemoryUse, ResourceRegistry};
use super::pipeline::{SceneSet, create_set_layout};
use super::validation::ValidationLog;
use crate::error::{Error, Result, VkContext};
use crate::kernels::{KernelVariant, TraceMode};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{CStr, c_char};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How long one submission may run before it is reported as a hang instead of waited on forever.
/// Lavapipe on two cores is the slowest device we support; its longest dispatch is far below this.
pub const SUBMIT_TIMEOUT: Duration = Duration::from_secs(600);

/// Environment variable that selects the device like `--device` (index or part of the name).
pub const DEVICE_ENV: &str = "GI_DEVICE";

/// Environment variable naming the Vulkan loader library to open instead of `libvulkan.so.1`.
pub const LOADER_ENV: &str = "GI_VULKAN_LOADER";

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable the Khronos validation layer, with its synchronization checks (missing or wrong
    /// barriers between the passes), and count its messages (always on in tests).
    pub validation: bool,
    /// Device index or a case-insensitive part of its name; `None` uses [`DEVICE_ENV`], then the
    /// best device (discrete > integrated > virtual > CPU).
    pub device: Option<String>,
    /// Which kernel variant traces rays.
    pub trace: TraceMode,
}

/// One Vulkan device ready to run the kernels.
///
/// Every resource made from it (buffers, images, kernels, ...) holds the `SharedDevice` and
/// frees itself when dropped; the device and instance go when the context and the last resource
/// are gone, whatever the order.
pub struct Context {
    /// What resources share; `device` below is its handle, kept for `ctx.device` calls.
    pub(crate) shared: Arc<SharedDevice>,
    pub(crate) device: ash::Device,
    validation: Option<Arc<ValidationLog>>,
    pub(crate) queue: vk::Queue,
    pub(crate) push_descriptor: ash::khr::push_descriptor::Device,
    command_pool: vk::CommandPool,
    capabilities: Capabilities,
    variant: KernelVariant,
    /// Layouts of the scene's sets 1 and 2 (`SceneSet`), shared by every kernel that traces.
    scene_set_layouts: [vk::DescriptorSetLayout; 2],
    /// `VK_EXT_debug_utils`' command labels, where the instance has the extension (ours, when
    /// the loader offers it): each pass's name in RenderDoc, Nsight and the validation layer.
    pub(crate) labels: Option<ash::ext::debug_utils::Device>,
}

/// The device-level state resources need to free themselves, shared by the context and every
/// resource (an `Arc`): the last owner waits for the device, frees the allocator's memory, and
/// destroys the device, then ([`Instance`]) the debug messenger and the instance.
pub(crate) struct SharedDevice {
    pub(crate) device: ash::Device,
    /// Ours, or the engine's ([`ExternalDevice::allocator`]): both are shared.
    pub(crate) allocator: ManuallyDrop<Arc<Mutex<Allocator>>>,
    pub(crate) accel: Option<ash::khr::acceleration_structure::Device>,
    pub(crate) buffers: ResourceRegistry<vk::Buffer>,
    pub(crate) images: ResourceRegistry<vk::Image>,
    /// Set once a wait reported the device lost or timed out: nothing is submitted or waited on
    /// after that (a hung device may never finish a wait).
    lost: AtomicBool,
    /// The instance when we created it and the device: dropped by `drop`, after the device and
    /// under the same lock. `None` for an engine's device ([`Context::from_external`]), which
    /// the engine destroys.
    instance: Option<Instance>,
}

/// Held while an instance or device is created or destroyed: loaders and drivers race there when
/// threads (parallel tests, an engine's worker threads) do it at once. Seen as a SIGSEGV of
/// lavapipe in CI; NVIDIA's driver 595 does the same (kvark/blade#336).
static LIFETIMES: Mutex<()> = Mutex::new(());

fn lifetimes() -> std::sync::MutexGuard<'static, ()> {
    LIFETIMES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl SharedDevice {
    fn is_lost(&self) -> bool {
        self.lost.load(Ordering::Acquire)
    }

    /// Waits until the device is idle, unless it is lost (a hung device might never be).
    fn wait_idle(&self) {
        if !self.is_lost() {
            unsafe { self.device.device_wait_idle() }.ok();
        }
    }
}

impl Drop for SharedDevice {
    fn drop(&mut self) {
        self.wait_idle();
        unsafe {
            ManuallyDrop::drop(&mut self.allocator);
            if let Some(instance) = self.instance.take() {
                let _held = lifetimes();
                self.device.destroy_device(None);
                drop(instance);
            }
        }
    }
}

/// The instance and its debug messenger, destroyed together: last of all, or as soon as
/// `Context::new` fails before a device exists.
struct Instance {
    instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    // The messenger's user data: alive while the messenger is.
    _validation: Option<Arc<ValidationLog>>,
    // The instance's function pointers come from the loader it holds.
    _entry: ash::Entry,
}

impl Drop for Instance {
    fn drop(&mut self) {
        unsafe {
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// Our own memory allocator for `device` (buffer device addresses for the ray-query variant's
/// acceleration structures).
fn new_allocator(
    instance: &ash::Instance,
    device: &ash::Device,
    physical_device: vk::PhysicalDevice,
    variant: KernelVariant,
) -> Result<Allocator> {
    Allocator::new(&AllocatorCreateDesc {
        instance: instance.clone(),
        device: device.clone(),
        physical_device,
        debug_settings: Default::default(),
        buffer_device_address: variant == KernelVariant::RayQuery,
        allocation_sizes: Default::default(),
    })
    .map_err(|e| Error::Allocation {
        what: "allocator".into(),
        bytes: None,
        why: e.to_string(),
    })
}

fn device_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 4,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 3,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 1,
        _ => 0,
    }
}

impl Context {
    /// Opens the loader, picks a device and enables exactly what the chosen kernel variant needs.
    pub fn new(options: &ContextOptions) -> Result<Self> {
        let held = lifetimes();
        let entry = match std::env::var_os(LOADER_ENV) {
            Some(path) => unsafe { ash::Entry::load_from(&path) }.map_err(|e| {
                Error::NoLoader(format!("{} ({LOADER_ENV}={})", e, path.to_string_lossy()))
            })?,
            None => unsafe { ash::Entry::load() }.map_err(|e| Error::NoLoader(e.to_string()))?,
        };

        let validation = if options.validation {
            let layers = unsafe { entry.enumerate_instance_layer_properties() }
                .vk("vkEnumerateInstanceLayerProperties")?;
            let found = layers
                .iter()
                .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
            if !found {
                return Err(Error::NoValidationLayer);
            }
            Some(Arc::new(ValidationLog::default()))
        } else {
            None
        };

        let app = vk::ApplicationInfo::default()
            .application_name(c"gi")
            .engine_name(c"gi")
            .api_version(vk::API_VERSION_1_2);
        let layer_ptrs: Vec<*const c_char> = if validation.is_some() {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };
        // Debug utils wherever the loader has it: the passes' labels, and validation's messenger.
        let debug_utils = validation.is_some()
            || unsafe { entry.enumerate_instance_extension_properties(None) }
                .unwrap_or_default()
                .iter()
                .any(|e| e.extension_name_as_c_str() == Ok(ash::ext::debug_utils::NAME));
        let mut ext_ptrs: Vec<*const c_char> = vec![];
        if debug_utils {
            ext_ptrs.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        if validation.is_some() {
            ext_ptrs.push(ash::ext::validation_features::NAME.as_ptr());
        }
        // VK_EXT_validation_features rather than VK_EXT_layer_settings: the layer of Debian
        // bookworm (1.3.239, what scripts/setup.sh installs) predates the latter, and later
        // layers still honour the former.
        let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        if validation.is_some() {
            instance_info = instance_info.push_next(&mut features);
        }
        let instance = match unsafe { entry.create_instance(&instance_info, None) } {
            Ok(i) => i,
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => {
                return Err(Error::NoDevice(icd_hint()));
            }
            Err(result) => {
                return Err(Error::Vulkan {
                    call: "vkCreateInstance",
                    result,
                });
            }
        };
        // From here on, `owner` destroys what exists if a later step fails.
        let mut owner = Instance {
            instance: instance.clone(),
            debug: None,
            _validation: validation.clone(),
            _entry: entry.clone(),
        };

        if let Some(log) = &validation {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(super::validation::callback))
                .user_data(Arc::as_ptr(log).cast_mut().cast());
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            owner.debug = Some((loader, messenger));
        }

        let physical_devices =
            unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
        if physical_devices.is_empty() {
            return Err(Error::NoDevice(icd_hint()));
        }
        let probed: Vec<_> = physical_devices
            .iter()
            .map(|&pd| (pd, unsafe { Capabilities::probe(&instance, pd) }))
            .collect();

        let wanted = options
            .device
            .clone()
            .or_else(|| std::env::var(DEVICE_ENV).ok().filter(|s| !s.is_empty()));
        let index = match &wanted {
            Some(w) => select_device(w, probed.iter().map(|(_, (c, _))| c.name.as_str()))?,
            None => probed
                .iter()
                .enumerate()
                .max_by_key(|(i, (_, (c, _)))| (device_rank(c.device_type), usize::MAX - i))
                .map(|(i, _)| i)
                .unwrap_or(0),
        };
        let (physical_device, (capabilities, extensions)) = probed
            .into_iter()
            .nth(index)
            .ok_or_else(|| Error::NoDevice(icd_hint()))?;

        let mut required = DeviceRequirements::of(
            &instance,
            physical_device,
            capabilities,
            &extensions,
            options.trace,
        )?;
        let (variant, queue_family) = (required.variant, required.queue_family);
        let device_exts: Vec<*const c_char> =
            required.extensions.iter().map(|e| e.as_ptr()).collect();
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut f2 = required.features.chain(variant == KernelVariant::RayQuery);
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&device_exts)
            .push_next(&mut f2);
        let device = unsafe { instance.create_device(physical_device, &device_info, None) }
            .vk("vkCreateDevice")?;
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = match new_allocator(&instance, &device, physical_device, variant) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_device(None) };
                return Err(e);
            }
        };
        // From here on, `shared` destroys the device and instance (taking the lock) if a later
        // step fails.
        drop(held);
        let shared = Arc::new(SharedDevice {
            device: device.clone(),
            allocator: ManuallyDrop::new(Arc::new(Mutex::new(allocator))),
            accel: (variant == KernelVariant::RayQuery)
                .then(|| ash::khr::acceleration_structure::Device::new(&instance, &device)),
            buffers: ResourceRegistry::default(),
            lost: AtomicBool::new(false),
            images: ResourceRegistry::default(),
            instance: Some(owner),
        });
        let mut ctx = Self::with_device(
            shared,
            &instance,
            validation,
            queue,
            queue_family,
            required.capabilities,
            variant,
        )?;
        if debug_utils {
            ctx.labels = Some(ash::ext::debug_utils::Device::new(&instance, &ctx.device));
        }
        Ok(ctx)
    }

    /// The context of a device that exists (`shared`): our command pool and scene layouts.
    fn with_device(
        shared: Arc<SharedDevice>,
        instance: &ash::Instance,
        validation: Option<Arc<ValidationLog>>,
        queue: vk::Queue,
        queue_family: u32,
        capabilities: Capabilities,
        variant: KernelVariant,
    ) -> Result<Self> {
        let device = shared.device.clone();
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let command_pool =
            unsafe { device.create_command_pool(&pool_info, None) }.vk("vkCreateCommandPool")?;
        let push_descriptor = ash::khr::push_descriptor::Device::new(instance, &device);

        let mut ctx = Self {
            shared,
            device,
            validation,
            queue,
            push_descriptor,
            command_pool,
            capabilities,
            variant,
            scene_set_layouts: [vk::DescriptorSetLayout::null(); 2],
            labels: None,
        };
        // Dropping `ctx` on an error frees what exists (destroying a null layout is a no-op).
        for (slot, set) in ctx
            .scene_set_layouts
            .iter_mut()
            .zip([SceneSet::Geometry, SceneSet::Shading])
        {
            let kinds = set.binding_slots(variant, ctx.capabilities.scene_texture_slots());
            *slot = create_set_layout(&ctx.device, &kinds, false)?;
        }
        Ok(ctx)
    }

    /// Wraps an engine's device (see [`ExternalDevice`]): the kernels run on its queue, and
    /// resources come from its allocator or from one made here. Nothing of the engine's is
    /// destroyed: dropping the context and every resource made from it (renderers, scenes,
    /// buffers) destroys only what this crate created (command pool, layouts, pipelines, buffers,
    /// images, our allocator); the last of them waits for the device to be idle first. Destroy the
    /// device after that.
    ///
    /// Errors, naming what is missing, when the physical device lacks a feature the kernels need,
    /// or when `device` was created without an extension or feature of
    /// [`DeviceRequirements::new`] (for `trace`), or `queue_family` has no compute.
    /// Validation messages are the engine's: [`Context::validation_messages`] is `None`.
    ///
    /// # Safety
    /// Every handle of `device` must be valid, belong together (device of the physical device
    /// of the instance, queue of the device and family, allocator of the device), and outlive
    /// the context and every resource made from it.
    pub unsafe fn from_external(device: ExternalDevice, trace: TraceMode) -> Result<Self> {
        let ExternalDevice {
            instance,
            physical_device,
            device,
            queue,
            queue_family,
            enabled_extensions,
            enabled_features,
            allocator,
        } = device;
        let required = unsafe { DeviceRequirements::new(&instance, physical_device, trace) }?;
        let name = &required.capabilities.name;
        for ext in &required.extensions {
            if !enabled_extensions.iter().any(|e| e.as_c_str() == *ext) {
                return Err(Error::MissingFeature {
                    device: name.clone(),
                    feature: format!(
                        "{} (not in ExternalDevice::enabled_extensions)",
                        ext.to_string_lossy()
                    ),
                    needed_for: "the kernels (enable DeviceRequirements::extensions)".into(),
                });
            }
        }
        if let Some(feature) = required.features.missing_in(&enabled_features) {
            return Err(Error::MissingFeature {
                device: name.clone(),
                feature: format!("{feature} (not in ExternalDevice::enabled_features)"),
                needed_for: "the kernels (enable DeviceRequirements::features)".into(),
            });
        }
        let families =
            unsafe { instance.get_physical_device_queue_family_properties(physical_device) };
        let compute = families
            .get(queue_family as usize)
            .is_some_and(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE));
        if !compute {
            return Err(Error::MissingFeature {
                device: name.clone(),
                feature: format!("compute on queue family {queue_family}"),
                needed_for: "every kernel (ExternalDevice::queue_family)".into(),
            });
        }
        let variant = required.variant;
        let allocator = match allocator {
            Some(a) => a,
            None => Arc::new(Mutex::new(new_allocator(
                &instance,
                &device,
                physical_device,
                variant,
            )?)),
        };
        let shared = Arc::new(SharedDevice {
            device: device.clone(),
            allocator: ManuallyDrop::new(allocator),
            accel: (variant == KernelVariant::RayQuery)
                .then(|| ash::khr::acceleration_structure::Device::new(&instance, &device)),
            buffers: ResourceRegistry::default(),
            lost: AtomicBool::new(false),
            images: ResourceRegistry::default(),
            instance: None,
        });
        Self::with_device(
            shared,
            &instance,
            None,
            queue,
            queue_family,
            required.capabilities,
            variant,
        )
    }

    /// The layouts of the scene's persistent sets, in set order (1 and 2).
    pub(crate) fn scene_set_layouts(&self) -> [vk::DescriptorSetLayout; 2] {
        self.scene_set_layouts
    }

    /// What the chosen device can do.
    pub fn capabilities(&self) -> &Capabilities {
        &self.capabilities
    }

    /// The kernel variant this context runs (ray queries or software BVH traversal).
    pub fn variant(&self) -> KernelVariant {
        self.variant
    }

    /// Whether the device was lost: a wait reported `VK_ERROR_DEVICE_LOST`, or a submission ran
    /// past [`SUBMIT_TIMEOUT`]. Every later submission fails at once with
    /// `VK_ERROR_DEVICE_LOST`; the context can only be dropped (without waiting for the device)
    /// and a new one created.
    pub fn is_lost(&self) -> bool {
        self.shared.is_lost()
    }

    /// The raw `ash` device, for engine teams that record their own commands around ours.
    pub fn device(&self) -> &ash::Device {
        &self.device
    }

    /// Every buffer alive on this context, in creation order: its name, size and the memory
    /// location it asked for. Tests use it to check that long-lived data is device-local.
    pub fn live_buffers(&self) -> Vec<BufferInfo> {
        self.shared.buffers.snapshot()
    }

    /// Every image alive on this context, in creation order: its name, the size of its memory
    /// and the location it asked for.
    pub fn live_images(&self) -> Vec<BufferInfo> {
        self.shared.images.snapshot()
    }

    /// The device memory the allocator holds now, from its report.
    pub fn device_memory(&self) -> DeviceMemoryUse {
        let report = match self.shared.allocator.lock() {
            Ok(a) => a.generate_report(),
            // Every allocator call is one step: its state is whole even after a panic elsewhere.
            Err(poisoned) => poisoned.into_inner().generate_report(),
        };
        DeviceMemoryUse {
            allocated: report.total_allocated_bytes,
            reserved: report.total_capacity_bytes,
            allocations: report.allocations.len(),
            blocks: report.blocks.len(),
        }
    }

    /// Validation messages (warnings and errors) seen so far; `None` when validation is off.
    pub fn validation_messages(&self) -> Option<Vec<String>> {
        self.validation.as_ref().map(|v| v.messages())
    }

    /// Tears the context down and returns every validation message, including those the layer
    /// prints while objects are destroyed (leaks); `None` when validation is off.
    ///
    /// Resources still alive keep the device until they are dropped, so their destruction and
    /// any leak would go unreported: that is reported as a message of its own.
    pub fn finish(self) -> Option<Vec<String>> {
        let log = self.validation.clone();
        let alive = Arc::strong_count(&self.shared) - 1;
        drop(self);
        log.map(|l| {
            let mut messages = l.messages();
            if alive > 0 {
                messages.push(format!(
                    "{alive} resources outlived Context::finish: drop them before"
                ));
            }
            messages
        })
    }

    /// Records commands with `record`, submits them, and waits (at most [`SUBMIT_TIMEOUT`]).
    pub fn submit<R>(&self, record: impl FnOnce(vk::CommandBuffer) -> R) -> Result<R> {
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc) }
            .vk("vkAllocateCommandBuffers")?[0];
        let result = self.record_and_wait(cmd, record);
        // A lost device's command buffer may still be pending: the pool frees it at the end.
        if !self.is_lost() {
            unsafe { self.device.free_command_buffers(self.command_pool, &[cmd]) };
        }
        result
    }

    fn record_and_wait<R>(
        &self,
        cmd: vk::CommandBuffer,
        record: impl FnOnce(vk::CommandBuffer) -> R,
    ) -> Result<R> {
        if self.is_lost() {
            return Err(Error::Vulkan {
                call: "vkQueueSubmit",
                result: vk::Result::ERROR_DEVICE_LOST,
            });
        }
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { self.device.begin_command_buffer(cmd, &begin) }.vk("vkBeginCommandBuffer")?;
        let out = record(cmd);
        unsafe { self.device.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
        let fence = unsafe {
            self.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .vk("vkCreateFence")?;
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let waited = unsafe { self.device.queue_submit(self.queue, &submit, fence) }
            .vk("vkQueueSubmit")
            .and_then(|()| {
                unsafe {
                    self.device
                        .wait_for_fences(&[fence], true, SUBMIT_TIMEOUT.as_nanos() as u64)
                }
                .vk("vkWaitForFences")
            });
        match &waited {
            Err(Error::Vulkan {
                result: vk::Result::ERROR_DEVICE_LOST | vk::Result::TIMEOUT,
                ..
            }) => {
                // Nothing more goes to the device, and nothing waits on it (a hung one may never
                // answer): the fence, perhaps still in use, is left to the process's end.
                self.shared.lost.store(true, Ordering::Release);
            }
            Err(_) => {
                // A failed submit: nothing is pending, unless the driver says otherwise.
                self.shared.wait_idle();
                unsafe { self.device.destroy_fence(fence, None) };
            }
            Ok(()) => unsafe { self.device.destroy_fence(fence, None) },
        }
        waited.map(|()| out)
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        self.shared.wait_idle();
        unsafe {
            self.device.destroy_command_pool(self.command_pool, None);
            for layout in self.scene_set_layouts {
                self.device.destroy_descriptor_set_layout(layout, None);
            }
        }
        // The device and instance go with the last holder of `shared`.
    }
}

/// An engine's Vulkan objects, for [`Context::from_external`]. The engine keeps ownership: the
/// context never destroys them.
///
/// The instance must have been created with `apiVersion` 1.2 or later, and the device with
/// every extension and feature of [`DeviceRequirements::new`] for the same physical device and
/// trace mode (they are checked against `enabled_extensions` and `enabled_features`, which must
/// say what the device was really created with).
#[derive(Clone)]
pub struct ExternalDevice {
    /// The engine's instance.
    pub instance: ash::Instance,
    /// The physical device of `device`.
    pub physical_device: vk::PhysicalDevice,
    /// The engine's device.
    pub device: ash::Device,
    /// The queue that [`Context::submit`] and the scene uploads use; it must be of
    /// `queue_family`. The engine must not use it from another thread during those calls
    /// (Vulkan's external synchronization of queues).
    pub queue: vk::Queue,
    /// The queue family of `queue` and of the command buffers the engine records our passes
    /// into; it must support compute.
    pub queue_family: u32,
    /// The device extensions the device was created with.
    pub enabled_extensions: Vec<std::ffi::CString>,
    /// The features the device was created with.
    pub enabled_features: FeatureChain,
    /// The engine's allocator, made for this device (with `buffer_device_address` for the
    /// ray-query variant); `None` makes one of ours, freed with the last resource.
    pub allocator: Option<Arc<Mutex<Allocator>>>,
}

/// What a device must enable for the kernels of one trace mode: create the device with
/// `extensions` and `features` (through [`FeatureChain::chain`], with
/// `variant == KernelVariant::RayQuery`), then hand it over with [`Context::from_external`].
#[derive(Clone)]
pub struct DeviceRequirements {
    /// What the physical device can do.
    pub capabilities: Capabilities,
    /// The kernel variant the trace mode resolves to on this device.
    pub variant: KernelVariant,
    /// Device extensions to enable.
    pub extensions: Vec<&'static CStr>,
    /// Features to enable (and nothing else is needed).
    pub features: FeatureChain,
    /// The first queue family with compute (any compute family will do).
    pub queue_family: u32,
}

impl DeviceRequirements {
    /// What `physical_device` must enable for `trace`'s kernels; errors name the first thing
    /// the physical device lacks.
    ///
    /// # Safety
    /// `physical_device` must belong to `instance`.
    pub unsafe fn new(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        trace: TraceMode,
    ) -> Result<Self> {
        let (capabilities, extensions) = unsafe { Capabilities::probe(instance, physical_device) };
        Self::of(instance, physical_device, capabilities, &extensions, trace)
    }

    fn of(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        capabilities: Capabilities,
        available: &[vk::ExtensionProperties],
        trace: TraceMode,
    ) -> Result<Self> {
        let variant = KernelVariant::resolve(trace, &capabilities)?;
        let features = required_features(&capabilities, variant)?;
        let queue_family =
            unsafe { instance.get_physical_device_queue_family_properties(physical_device) }
                .iter()
                .position(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
                .ok_or_else(|| Error::MissingFeature {
                    device: capabilities.name.clone(),
                    feature: "a compute queue".into(),
                    needed_for: "every kernel".into(),
                })? as u32;
        let mut extensions = vec![ash::khr::push_descriptor::NAME];
        if variant == KernelVariant::RayQuery {
            extensions.extend([
                ash::khr::acceleration_structure::NAME,
                ash::khr::ray_query::NAME,
                ash::khr::deferred_host_operations::NAME,
            ]);
        }
        debug_assert!(
            extensions
                .iter()
                .all(|e| super::capabilities::has_extension(available, e))
        );
        Ok(Self {
            capabilities,
            variant,
            extensions,
            features,
            queue_family,
        })
    }
}

fn icd_hint() -> String {
    match std::env::var("VK_ICD_FILENAMES").or_else(|_| std::env::var("VK_DRIVER_FILES")) {
        Ok(v) => format!(" (the driver list is overridden: VK_ICD_FILENAMES/VK_DRIVER_FILES={v})"),
        Err(_) => String::new(),
    }
}

/// Picks a device by index or by a case-insensitive part of its name.
pub fn select_device<'a>(wanted: &str, names: impl Iterator<Item = &'a str>) -> Result<usize> {
    let names: Vec<&str> = names.collect();
    let found = match wanted.trim().parse::<usize>() {
        Ok(i) => (i < names.len()).then_some(i),
        Err(_) => {
            let w = wanted.to_lowercase();
            names.iter().position(|n| n.to_lowercase().contains(&w))
        }
    };
    found.ok_or_else(|| Error::DeviceNotFound {
        wanted: wanted.to_string(),
        available: names
            .iter()
            .enumerate()
            .map(|(i, n)| format!("{i}: {n}"))
            .collect::<Vec<_>>()
            .join(", "),
    })
}

/// The device features the kernels use, and nothing else; an error names the first one missing.
fn required_features(caps: &Capabilities, variant: KernelVariant) -> Result<FeatureChain> {
    let missing = |feature: &str, needed_for: &str| Error::MissingFeature {
        device: caps.name.clone(),
        feature: feature.into(),
        needed_for: needed_for.into(),
    };
    if caps.api_version < vk::API_VERSION_1_2 {
        return Err(missing("Vulkan 1.2", "SPIR-V 1.5 kernels"));
    }
    if !caps.push_descriptor {
        return Err(missing(
            "VK_KHR_push_descriptor",
            "binding kernel resources",
        ));
    }
    let mut f = FeatureChain::default();
    if !caps.vulkan_memory_model {
        return Err(missing(
            "vulkanMemoryModel",
            "rust-gpu kernels (Vulkan memory model)",
        ));
    }
    f.v12.vulkan_memory_model = vk::TRUE;
    if !caps.bindless_textures {
        return Err(missing(
            "runtimeDescriptorArray, shaderSampledImageArrayNonUniformIndexing and \
             descriptorBindingPartiallyBound (descriptor indexing)",
            "the scene's texture array",
        ));
    }
    f.v12.runtime_descriptor_array = vk::TRUE;
    f.v12.shader_sampled_image_array_non_uniform_indexing = vk::TRUE;
    f.v12.descriptor_binding_partially_bound = vk::TRUE;
    for cap in gi_shared::abi::KERNEL_CAPABILITIES {
        let subgroup = |op| caps.subgroup_operations.contains(op);
        let (have, name) = match *cap {
            "Int8" => (caps.shader_int8, "shaderInt8"),
            "Int16" => (caps.shader_int16, "shaderInt16"),
            "Int64" => (caps.shader_int64, "shaderInt64"),
            "VulkanMemoryModelDeviceScope" => (
                caps.vulkan_memory_model_device_scope,
                "vulkanMemoryModelDeviceScope",
            ),
            "GroupNonUniform" => (
                subgroup(vk::SubgroupFeatureFlags::BASIC),
                "subgroup basic operations in compute shaders (VK_SUBGROUP_FEATURE_BASIC_BIT)",
            ),
            "GroupNonUniformArithmetic" => (
                subgroup(vk::SubgroupFeatureFlags::ARITHMETIC),
                "subgroup arithmetic in compute shaders (VK_SUBGROUP_FEATURE_ARITHMETIC_BIT)",
            ),
            // Core in Vulkan 1.2: no feature to enable.
            "ShaderNonUniform" => (true, "ShaderNonUniform"),
            "RuntimeDescriptorArray" | "SampledImageArrayNonUniformIndexing" => (
                caps.bindless_textures,
                "runtimeDescriptorArray and shaderSampledImageArrayNonUniformIndexing",
            ),
            "StorageBufferArrayNonUniformIndexing" => (
                caps.storage_buffer_arrays,
                "shaderStorageBufferArrayNonUniformIndexing (the scene's split arrays)",
            ),
            other => (false, other),
        };
        if !have {
            return Err(missing(name, "the kernels' SPIR-V capabilities"));
        }
        match *cap {
            "Int8" => f.v12.shader_int8 = vk::TRUE,
            "Int16" => f.core.shader_int16 = vk::TRUE,
            "Int64" => f.core.shader_int64 = vk::TRUE,
            "VulkanMemoryModelDeviceScope" => f.v12.vulkan_memory_model_device_scope = vk::TRUE,
            "StorageBufferArrayNonUniformIndexing" => {
                f.v12.shader_storage_buffer_array_non_uniform_indexing = vk::TRUE
            }
            // Subgroup operations are properties, not features: nothing to enable.
            _ => {}
        }
    }
    if variant == KernelVariant::RayQuery {
        f.v12.buffer_device_address = vk::TRUE;
        f.accel.acceleration_structure = vk::TRUE;
        f.ray_query.ray_query = vk::TRUE;
    }
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_selection_by_index_and_name() {
        let names = ["llvmpipe (LLVM 15)", "NVIDIA H100"];
        assert_eq!(select_device("1", names.iter().copied()).unwrap(), 1);
        assert_eq!(select_device("nvidia", names.iter().copied()).unwrap(), 1);
        assert_eq!(select_device("LLVMpipe", names.iter().copied()).unwrap(), 0);
        let err = select_device("7", names.iter().copied()).unwrap_err();
        assert!(err.to_string().contains("0: llvmpipe"), "{err}");
        assert!(select_device("radeon", names.iter().copied()).is_err());
    }

    #[test]
    fn devices_without_what_the_kernels_declare_are_refused_by_name() {
        let full = Capabilities::for_tests(false);
        let f = required_features(&full, KernelVariant::Software).unwrap();
        assert_eq!(f.v12.vulkan_memory_model_device_scope, vk::TRUE);
        let no_arithmetic = Capabilities {
            subgroup_operations: vk::SubgroupFeatureFlags::BASIC,
            ..full.clone()
        };
        let err = required_features(&no_arithmetic, KernelVariant::Software)
            .map(drop)
            .unwrap_err();
        assert!(err.to_string().contains("subgroup arithmetic"), "{err}");
        let no_device_scope = Capabilities {
            vulkan_memory_model_device_scope: false,
            ..full
        };
        let err = required_features(&no_device_scope, KernelVariant::Software)
            .map(drop)
            .unwrap_err();
        assert!(
            err.to_string().contains("vulkanMemoryModelDeviceScope"),
            "{err}"
        );
        let no_bindless = Capabilities {
            bindless_textures: false,
            ..Capabilities::for_tests(false)
        };
        let err = required_features(&no_bindless, KernelVariant::Software)
            .map(drop)
            .unwrap_err();
        assert!(err.to_string().contains("runtimeDescriptorArray"), "{err}");
        assert!(err.to_string().contains("texture array"), "{err}");
    }

    #[test]
    fn an_engine_device_lacking_a_required_feature_is_named() {
        let caps = Capabilities::for_tests(true);
        let software = required_features(&caps, KernelVariant::Software).unwrap();
        assert_eq!(software.missing_in(&software), None);
        let mut enabled = software;
        enabled.v12.vulkan_memory_model_device_scope = vk::FALSE;
        assert_eq!(
            software.missing_in(&enabled),
            Some("vulkanMemoryModelDeviceScope")
        );
        // More than required is fine; ray queries need what the software device lacks.
        let ray_query = required_features(&caps, KernelVariant::RayQuery).unwrap();
        assert_eq!(ray_query.missing_in(&ray_query), None);
        assert_eq!(software.missing_in(&ray_query), None);
        assert_eq!(ray_query.missing_in(&software), Some("bufferDeviceAddress"));
        assert!(ray_query.missing_in(&FeatureChain::default()).is_some());
    }

    #[test]
    fn every_kernel_capability_maps_to_a_device_feature() {
        for cap in gi_shared::abi::KERNEL_CAPABILITIES {
            assert!(
                [
                    "Int8",
                    "Int16",
                    "Int64",
                    "VulkanMemoryModelDeviceScope",
                    "GroupNonUniform",
                    "GroupNonUniformArithmetic",
                    "ShaderNonUniform",
                    "RuntimeDescriptorArray",
                    "SampledImageArrayNonUniformIndexing",
                    "StorageBufferArrayNonUniformIndexing"
                ]
                .contains(cap),
                "capability {cap} has no device feature mapping"
            );
        }
    }
}
