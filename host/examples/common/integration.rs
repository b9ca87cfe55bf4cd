//! An engine's side of the integration, as short as it gets: its own instance, device, queue,
//! output image and command buffer; our passes recorded into that command buffer
//! (`gi_host::engine`). Shared by the `minimal` and `headless` examples and the `engine_api`
//! test.

use ash::vk;
use gi_host::TraceMode;
use gi_host::engine::{
    Context, DeviceRequirements, ExternalDevice, FrameInputs, FrameOutputs, GiRenderer, GiSettings,
    GpuScene, OUTPUT_ACCESS, OUTPUT_FORMAT, OUTPUT_STAGE, OutputImage, Scene, ViewOptions,
};
use gi_host::gbuffer::scene_camera;
use gi_host::image_io::HdrImage;
use std::error::Error;
use std::ffi::{CString, c_char, c_void};
use std::sync::Mutex;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// The validation layer's messages, collected by [`on_message`].
static MESSAGES: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn on_message(
    _severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    let text = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) }
        .map_or_else(|| "?".to_owned(), |m| m.to_string_lossy().into_owned());
    MESSAGES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(text);
    vk::FALSE
}

/// What [`render`] made.
pub struct Rendered {
    /// The last frame's image, read back from the engine's output image.
    pub image: HdrImage,
    /// Validation warnings and errors (empty without validation).
    pub validation_messages: Vec<String>,
}

/// Renders `frames` frames of `scene` at `width × height` on a device of our own making, with
/// the validation layer (synchronization checks on) when `validation`.
pub fn render(
    scene: &Scene,
    (width, height): (u32, u32),
    frames: u32,
    trace: TraceMode,
    validation: bool,
) -> Result<Rendered> {
    let entry = unsafe { ash::Entry::load() }?;
    let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
    let extensions = [ash::ext::debug_utils::NAME.as_ptr()];
    let (layers, extensions): (&[*const c_char], &[*const c_char]) = match validation {
        true => (&layers, &extensions),
        false => (&[], &[]),
    };
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
    let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(layers)
        .enabled_extension_names(extensions);
    if validation {
        info = info.push_next(&mut features);
    }
    let instance = unsafe { entry.create_instance(&info, None) }?;
    let debug = ash::ext::debug_utils::Instance::new(&entry, &instance);
    let messenger = match validation {
        true => Some(unsafe {
            debug.create_debug_utils_messenger(
                &vk::DebugUtilsMessengerCreateInfoEXT::default()
                    .message_severity(
                        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                    )
                    .message_type(
                        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                            | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                    )
                    .pfn_user_callback(Some(on_message)),
                None,
            )
        }?),
        false => None,
    };
    let result = render_on(&instance, scene, (width, height), frames, trace);
    unsafe {
        if let Some(m) = messenger {
            debug.destroy_debug_utils_messenger(m, None);
        }
        instance.destroy_instance(None);
    }
    let validation_messages =
        std::mem::take(&mut *MESSAGES.lock().unwrap_or_else(|e| e.into_inner()));
    Ok(Rendered {
        image: result?,
        validation_messages,
    })
}

/// The device part of [`render`]: the first device that meets GI's requirements.
fn render_on(
    instance: &ash::Instance,
    scene: &Scene,
    size: (u32, u32),
    frames: u32,
    trace: TraceMode,
) -> Result<HdrImage> {
    let (physical_device, required) = unsafe { instance.enumerate_physical_devices() }?
        .into_iter()
        .find_map(|pd| {
            let required = unsafe { DeviceRequirements::new(instance, pd, trace) };
            required.ok().map(|r| (pd, r))
        })
        .ok_or("no Vulkan device meets the GI kernels' requirements")?;
    // The engine would add its own extensions and features to these.
    let names: Vec<*const c_char> = required.extensions.iter().map(|e| e.as_ptr()).collect();
    let mut features = required.features;
    let ray_query = required.variant == gi_host::KernelVariant::RayQuery;
    let mut chain = features.chain(ray_query);
    let priorities = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(required.queue_family)
        .queue_priorities(&priorities)];
    let info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_extension_names(&names)
        .push_next(&mut chain);
    let device = unsafe { instance.create_device(physical_device, &info, None) }?;
    let queue = unsafe { device.get_device_queue(required.queue_family, 0) };
    let external = ExternalDevice {
        instance: instance.clone(),
        physical_device,
        device: device.clone(),
        queue,
        queue_family: required.queue_family,
        enabled_extensions: required
            .extensions
            .iter()
            .map(|&e| CString::from(e))
            .collect(),
        enabled_features: required.features,
        allocator: None,
    };
    let image =
        EngineFrame::new(instance, physical_device, &device, &required, size).and_then(|engine| {
            let image = draw(&engine, external, scene, frames, trace);
            engine.destroy(&device);
            image
        });
    unsafe { device.destroy_device(None) };
    image
}

/// Our passes in the engine's frames; everything of ours is dropped before it returns.
fn draw(
    engine: &EngineFrame,
    external: ExternalDevice,
    scene: &Scene,
    frames: u32,
    trace: TraceMode,
) -> Result<HdrImage> {
    let device = external.device.clone();
    let ctx = unsafe { Context::from_external(external, trace) }?;
    let (width, height) = engine.size;
    let (lights, mut gpu_scene) = GpuScene::upload_lit(&ctx, scene, None, true)?;
    let settings = GiSettings::for_resolution(width, height);
    let mut gi = GiRenderer::new(
        &ctx,
        &lights,
        width,
        height,
        settings,
        ViewOptions::default(),
    )?;
    let camera = scene_camera(scene, width, height);
    let output = OutputImage {
        image: engine.image,
        format: OUTPUT_FORMAT,
        width,
        height,
        layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
    };
    for frame in 0..frames {
        let cmd = engine.cmd;
        unsafe {
            device.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())?;
            // The engine's barrier before our use: here after our copy of the frame before.
            let old = if frame == 0 {
                vk::ImageLayout::UNDEFINED
            } else {
                output.layout
            };
            engine.image_barrier(
                &device,
                (OUTPUT_STAGE, OUTPUT_ACCESS),
                (OUTPUT_STAGE, OUTPUT_ACCESS),
                (old, output.layout),
            );
        }
        gi.record(
            &ctx,
            cmd,
            &mut gpu_scene,
            &FrameInputs::new(camera),
            &FrameOutputs {
                image: Some(output),
                irradiance: None,
            },
        )?;
        unsafe {
            if frame + 1 == frames {
                // The engine's barrier after our use: a copy to the host.
                engine.image_barrier(
                    &device,
                    (OUTPUT_STAGE, OUTPUT_ACCESS),
                    (
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_READ,
                    ),
                    (output.layout, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                );
                let region = vk::BufferImageCopy::default()
                    .image_subresource(COLOR_LAYER)
                    .image_extent(vk::Extent3D {
                        width,
                        height,
                        depth: 1,
                    });
                device.cmd_copy_image_to_buffer(
                    cmd,
                    engine.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    engine.readback,
                    &[region],
                );
                let to_host = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[to_host],
                    &[],
                    &[],
                );
            }
            device.end_command_buffer(cmd)?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            device.queue_submit(engine.queue, &[submit], engine.fence)?;
            device.wait_for_fences(&[engine.fence], true, u64::MAX)?;
            device.reset_fences(&[engine.fence])?;
        }
    }
    let texels = unsafe {
        let bytes = (width * height * 16) as usize;
        let mapped = device.map_memory(
            engine.readback_memory,
            0,
            bytes as u64,
            vk::MemoryMapFlags::empty(),
        )?;
        let texels: Vec<[f32; 4]> =
            std::slice::from_raw_parts(mapped.cast::<[f32; 4]>(), bytes / 16).to_vec();
        device.unmap_memory(engine.readback_memory);
        texels
    };
    Ok(HdrImage::from_pixels(
        width,
        height,
        texels.iter().map(|t| [t[0], t[1], t[2]]).collect(),
    )?)
}

const COLOR_LAYER: vk::ImageSubresourceLayers = vk::ImageSubresourceLayers {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    mip_level: 0,
    base_array_layer: 0,
    layer_count: 1,
};

/// What the engine owns for its frames: the output image, a host-visible buffer to read it back,
/// a command buffer and a fence.
struct EngineFrame {
    size: (u32, u32),
    queue: vk::Queue,
    image: vk::Image,
    image_memory: vk::DeviceMemory,
    readback: vk::Buffer,
    readback_memory: vk::DeviceMemory,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl EngineFrame {
    fn new(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        device: &ash::Device,
        required: &DeviceRequirements,
        (width, height): (u32, u32),
    ) -> Result<Self> {
        let types = unsafe { instance.get_physical_device_memory_properties(physical_device) };
        let memory = |req: vk::MemoryRequirements, flags: vk::MemoryPropertyFlags| {
            let index = (0..types.memory_type_count)
                .find(|&i| {
                    req.memory_type_bits & (1 << i) != 0
                        && types.memory_types[i as usize]
                            .property_flags
                            .contains(flags)
                })
                .ok_or("no suitable memory type")?;
            let info = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(index);
            Ok::<_, Box<dyn Error>>(unsafe { device.allocate_memory(&info, None) }?)
        };
        unsafe {
            let image = device.create_image(
                &vk::ImageCreateInfo::default()
                    .image_type(vk::ImageType::TYPE_2D)
                    .format(OUTPUT_FORMAT)
                    .extent(vk::Extent3D {
                        width,
                        height,
                        depth: 1,
                    })
                    .mip_levels(1)
                    .array_layers(1)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC),
                None,
            )?;
            let image_memory = memory(
                device.get_image_memory_requirements(image),
                vk::MemoryPropertyFlags::DEVICE_LOCAL,
            )?;
            device.bind_image_memory(image, image_memory, 0)?;
            let readback = device.create_buffer(
                &vk::BufferCreateInfo::default()
                    .size(u64::from(width * height * 16))
                    .usage(vk::BufferUsageFlags::TRANSFER_DST),
                None,
            )?;
            let readback_memory = memory(
                device.get_buffer_memory_requirements(readback),
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
            )?;
            device.bind_buffer_memory(readback, readback_memory, 0)?;
            let pool = device.create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(required.queue_family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )?;
            let cmd = device.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .command_buffer_count(1),
            )?[0];
            let fence = device.create_fence(&vk::FenceCreateInfo::default(), None)?;
            Ok(Self {
                size: (width, height),
                queue: device.get_device_queue(required.queue_family, 0),
                image,
                image_memory,
                readback,
                readback_memory,
                pool,
                cmd,
                fence,
            })
        }
    }

    /// Records a barrier on the output image from `src` to `dst` (stages, accesses), between
    /// `layouts` (old, new).
    unsafe fn image_barrier(
        &self,
        device: &ash::Device,
        src: (vk::PipelineStageFlags, vk::AccessFlags),
        dst: (vk::PipelineStageFlags, vk::AccessFlags),
        (old, new): (vk::ImageLayout, vk::ImageLayout),
    ) {
        let barrier = vk::ImageMemoryBarrier::default()
            .src_access_mask(src.1)
            .dst_access_mask(dst.1)
            .old_layout(old)
            .new_layout(new)
            .image(self.image)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 0,
                layer_count: 1,
            });
        unsafe {
            device.cmd_pipeline_barrier(
                self.cmd,
                src.0,
                dst.0,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier],
            )
        };
    }

    fn destroy(self, device: &ash::Device) {
        unsafe {
            device.device_wait_idle().ok();
            device.destroy_fence(self.fence, None);
            device.destroy_command_pool(self.pool, None);
            device.destroy_buffer(self.readback, None);
            device.free_memory(self.readback_memory, None);
            device.destroy_image(self.image, None);
            device.free_memory(self.image_memory, None);
        }
    }
}
