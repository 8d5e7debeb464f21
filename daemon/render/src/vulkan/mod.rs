//! One Vulkan device and the two pipelines of a frame: the light's view into a shadow map,
//! then the camera's, shaded and shadowed, into an offscreen image that is read back (its
//! edges smoothed on the way: [`crate::smoothing`]). Dynamic rendering (Vulkan 1.3) needs no
//! render pass objects; Vulkan is loaded at run time, so a machine without it gets an error,
//! not a crash.

use ash::vk;
use glam::DVec3;

use crate::camera::Camera;
use crate::light;
use crate::mesh::Mesh;
use crate::picture::Picture;

mod frame;

use frame::Frame;

/// Largest picture edge, pixels.
pub const MAX_EDGE: u32 = 8192;

const COLOUR: vk::Format = vk::Format::R8G8B8A8_UNORM;

const DEPTH: vk::Format = vk::Format::D32_SFLOAT;

/// Edge of the shadow map, texels: about two millimetres each over a desk-sized view, and
/// cheap to draw and read on a CPU rasteriser.
const SHADOW_EDGE: u32 = 512;

/// Where a vertex that casts no shadow is put in the light's view: past its far plane.
const NO_SHADOW: [f32; 4] = [0.0, 0.0, 2.0, 1.0];

/// What a depth image is cleared to: the farthest depth.
const CLEAR_DEPTH: vk::ClearValue = vk::ClearValue {
    depth_stencil: vk::ClearDepthStencilValue {
        depth: 1.0,
        stencil: 0,
    },
};

/// The vertex as the shaders read it: clip position, normal, colour, and its clip position
/// in the light's view.
#[repr(C)]
#[derive(Clone, Copy)]
struct GpuVertex {
    clip: [f32; 4],
    normal: [f32; 3],
    colour: [f32; 4],
    light: [f32; 4],
}

/// Why nothing can be drawn.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unavailable(pub String);

impl std::fmt::Display for Unavailable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Unavailable {}

fn failed(what: &str) -> impl Fn(vk::Result) -> Unavailable + '_ {
    move |e| Unavailable(format!("{what}: {e}"))
}

/// A Vulkan device ready to draw.
pub struct Renderer {
    _entry: ash::Entry,
    instance: ash::Instance,
    device: ash::Device,
    memory_types: vk::PhysicalDeviceMemoryProperties,
    queue: vk::Queue,
    pool: vk::CommandPool,
    /// The shadow map's binding, as both pipelines see it.
    set_layout: vk::DescriptorSetLayout,
    descriptors: vk::DescriptorPool,
    set: vk::DescriptorSet,
    sampler: vk::Sampler,
    layout: vk::PipelineLayout,
    /// The camera's view.
    pipeline: vk::Pipeline,
    /// The light's view, depth only.
    shadow_pipeline: vk::Pipeline,
    /// Whether pictures get shadows and smoothed edges (see [`Renderer::set_depth_cues`]).
    depth_cues: bool,
    /// The images and buffers of the last frame, kept for the next one of the same size.
    frame: Option<Frame>,
    /// The device's name, as its driver gives it.
    device_name: String,
}

/// An image or buffer with its memory.
struct Allocation {
    memory: vk::DeviceMemory,
}

/// Whose view a pipeline draws.
#[derive(Clone, Copy, PartialEq, Eq)]
enum View {
    /// The camera's: the picture.
    Camera,
    /// The light's: the shadow map.
    Light,
}

impl Renderer {
    /// Load Vulkan and make a device that can draw (the first that has a graphics queue).
    pub fn new() -> Result<Self, Unavailable> {
        // SAFETY: loading the system's Vulkan loader; its functions are used as Vulkan says.
        let entry = unsafe { ash::Entry::load() }
            .map_err(|e| Unavailable(format!("no Vulkan loader (libvulkan.so.1): {e}")))?;
        let app = vk::ApplicationInfo::default()
            .application_name(c"hapticd")
            .api_version(vk::API_VERSION_1_3);
        let info = vk::InstanceCreateInfo::default().application_info(&app);
        // SAFETY: valid create info; the instance is destroyed in Drop.
        let instance = unsafe { entry.create_instance(&info, None) }
            .map_err(failed("creating a Vulkan instance"))?;
        match Self::with_instance(entry, instance.clone()) {
            Ok(renderer) => Ok(renderer),
            Err(e) => {
                // SAFETY: nothing made from the instance survives.
                unsafe { instance.destroy_instance(None) };
                Err(e)
            }
        }
    }

    fn with_instance(entry: ash::Entry, instance: ash::Instance) -> Result<Self, Unavailable> {
        // SAFETY: queries on a live instance.
        let devices = unsafe { instance.enumerate_physical_devices() }
            .map_err(failed("listing Vulkan devices"))?;
        let (physical, family, device_name) = devices
            .iter()
            .find_map(|&d| {
                // SAFETY: as above.
                let properties = unsafe { instance.get_physical_device_properties(d) };
                if properties.api_version < vk::API_VERSION_1_3 {
                    return None;
                }
                // SAFETY: as above.
                unsafe { instance.get_physical_device_queue_family_properties(d) }
                    .iter()
                    .position(|q| q.queue_flags.contains(vk::QueueFlags::GRAPHICS))
                    .map(|f| {
                        let name = properties
                            .device_name_as_c_str()
                            .map(|n| n.to_string_lossy().into_owned())
                            .unwrap_or_default();
                        (d, f as u32, name)
                    })
            })
            .ok_or_else(|| Unavailable("no Vulkan 1.3 device with a graphics queue".into()))?;
        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family)
            .queue_priorities(&priorities)];
        let mut v13 = vk::PhysicalDeviceVulkan13Features::default().dynamic_rendering(true);
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .push_next(&mut v13);
        // SAFETY: valid create info for a device of this instance.
        let device = unsafe { instance.create_device(physical, &info, None) }
            .map_err(failed("creating the Vulkan device"))?;
        // SAFETY: the queue family and index exist on this device.
        let queue = unsafe { device.get_device_queue(family, 0) };
        // SAFETY: as above.
        let memory_types = unsafe { instance.get_physical_device_memory_properties(physical) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info; destroyed in Drop.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .map_err(failed("creating a command pool"))?;
        let (set_layout, descriptors, set, sampler) = Self::shadow_binding(&device)?;
        let set_layouts = [set_layout];
        // SAFETY: a layout of the one set; destroyed in Drop.
        let layout = unsafe {
            device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts),
                None,
            )
        }
        .map_err(failed("creating the pipeline layout"))?;
        let pipeline = Self::pipeline(&device, layout, View::Camera)?;
        let shadow_pipeline = Self::pipeline(&device, layout, View::Light)?;
        Ok(Self {
            _entry: entry,
            instance,
            device,
            memory_types,
            queue,
            pool,
            set_layout,
            descriptors,
            set,
            sampler,
            layout,
            pipeline,
            shadow_pipeline,
            depth_cues: true,
            frame: None,
            device_name,
        })
    }

    /// The shadow map's binding: a depth image and a comparing sampler, in one set that
    /// each frame points at its own map.
    fn shadow_binding(
        device: &ash::Device,
    ) -> Result<
        (
            vk::DescriptorSetLayout,
            vk::DescriptorPool,
            vk::DescriptorSet,
            vk::Sampler,
        ),
        Unavailable,
    > {
        let bindings = [
            (0, vk::DescriptorType::SAMPLED_IMAGE),
            (1, vk::DescriptorType::SAMPLER),
        ]
        .map(|(binding, kind)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::FRAGMENT)
        });
        let sizes = [
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::SAMPLED_IMAGE)
                .descriptor_count(1),
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::SAMPLER)
                .descriptor_count(1),
        ];
        // Outside the map everything is lit: a border of the farthest depth.
        let sampler_info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .border_color(vk::BorderColor::FLOAT_OPAQUE_WHITE)
            .compare_enable(true)
            .compare_op(vk::CompareOp::LESS_OR_EQUAL);
        // SAFETY: valid create infos; everything is destroyed in Drop (the set with its pool).
        unsafe {
            let set_layout = device
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                    None,
                )
                .map_err(failed("creating the shadow map's binding"))?;
            let pool = device
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(1)
                        .pool_sizes(&sizes),
                    None,
                )
                .map_err(failed("creating the descriptor pool"))?;
            let layouts = [set_layout];
            let set = device
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(pool)
                        .set_layouts(&layouts),
                )
                .map_err(failed("allocating the shadow map's set"))?[0];
            let sampler = device
                .create_sampler(&sampler_info, None)
                .map_err(failed("creating the shadow sampler"))?;
            Ok((set_layout, pool, set, sampler))
        }
    }

    /// Draw shadows and smooth edges (the default), or neither: pictures a slow device
    /// draws sooner, flat as they were before.
    pub fn set_depth_cues(&mut self, on: bool) {
        self.depth_cues = on;
    }

    /// The device drawn on, as its driver names it (`llvmpipe (LLVM 15.0.6, 256 bits)`).
    pub fn device_name(&self) -> &str {
        &self.device_name
    }

    /// The pipeline drawing `view`: the camera's, shaded and blended into a colour image;
    /// or the light's, depth only, into the shadow map.
    fn pipeline(
        device: &ash::Device,
        layout: vk::PipelineLayout,
        view: View,
    ) -> Result<vk::Pipeline, Unavailable> {
        // Destroyed below once the pipeline holds it.
        let module = Self::shader_module(device)?;
        let stages = Self::shader_stages(module, view);
        let colour = view == View::Camera;
        let bindings = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(std::mem::size_of::<GpuVertex>() as u32)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let attributes = [
            (0, vk::Format::R32G32B32A32_SFLOAT, 0),
            (1, vk::Format::R32G32B32_SFLOAT, 16),
            (2, vk::Format::R32G32B32A32_SFLOAT, 28),
            (3, vk::Format::R32G32B32A32_SFLOAT, 44),
        ]
        .map(|(location, format, offset)| {
            vk::VertexInputAttributeDescription::default()
                .location(location)
                .binding(0)
                .format(format)
                .offset(offset)
        });
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&bindings)
            .vertex_attribute_descriptions(&attributes);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        // Both sides drawn: meshes need no consistent winding, and depth hides the back. The
        // light's depths are pushed back by a slope-scaled bias, so that a surface does not
        // shadow itself.
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .depth_bias_enable(view == View::Light)
            .depth_bias_constant_factor(1.5)
            .depth_bias_slope_factor(2.0)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(true)
            .src_color_blend_factor(vk::BlendFactor::SRC_ALPHA)
            .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
            .color_blend_op(vk::BlendOp::ADD)
            .src_alpha_blend_factor(vk::BlendFactor::ONE)
            .dst_alpha_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
            .alpha_blend_op(vk::BlendOp::ADD)
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend = vk::PipelineColorBlendStateCreateInfo::default()
            .attachments(&blend_attachments[..usize::from(colour)]);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let formats = [COLOUR];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&formats[..usize::from(colour)])
            .depth_attachment_format(DEPTH);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: every state the info points to lives until the call returns.
        let pipelines =
            unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) };
        // SAFETY: the pipeline (if made) keeps what it needs of the module.
        unsafe { device.destroy_shader_module(module, None) };
        let pipeline =
            pipelines.map_err(|(_, e)| Unavailable(format!("creating the pipeline: {e}")))?[0];
        Ok(pipeline)
    }

    /// Load the shaders (naga's SPIR-V, built with the crate) into a module.
    fn shader_module(device: &ash::Device) -> Result<vk::ShaderModule, Unavailable> {
        let bytes = include_bytes!(concat!(env!("OUT_DIR"), "/mesh.spv"));
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
            .collect();
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid SPIR-V from naga; the caller destroys it once the pipeline holds it.
        let module = unsafe { device.create_shader_module(&info, None) };
        module.map_err(failed("loading the shaders"))
    }

    /// The stages drawing `view` from `module` (the light's writes depth alone: no fragment).
    fn shader_stages(
        module: vk::ShaderModule,
        view: View,
    ) -> Vec<vk::PipelineShaderStageCreateInfo<'static>> {
        let (vertex, fragment) = match view {
            View::Camera => (c"vertex_main", Some(c"fragment_main")),
            View::Light => (c"shadow_main", None),
        };
        let mut stages = vec![
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(module)
                .name(vertex),
        ];
        stages.extend(fragment.map(|name| {
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(module)
                .name(name)
        }));
        stages
    }

    fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Result<u32, Unavailable> {
        (0..self.memory_types.memory_type_count)
            .find(|&i| {
                bits & (1 << i) != 0
                    && self.memory_types.memory_types[i as usize]
                        .property_flags
                        .contains(flags)
            })
            .ok_or_else(|| Unavailable(format!("no memory with properties {:#x}", flags.as_raw())))
    }

    fn allocate(
        &self,
        requirements: vk::MemoryRequirements,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<Allocation, Unavailable> {
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(requirements.size)
            .memory_type_index(self.memory_type(requirements.memory_type_bits, flags)?);
        // SAFETY: valid allocate info; freed by the caller.
        let memory = unsafe { self.device.allocate_memory(&info, None) }
            .map_err(failed("allocating memory"))?;
        Ok(Allocation { memory })
    }

    /// Draw `meshes` seen by `camera` on a `width × height` picture over `background`.
    pub fn draw(
        &mut self,
        meshes: &[&Mesh],
        camera: &Camera,
        (width, height): (u32, u32),
        background: [f32; 4],
    ) -> Result<Picture, Unavailable> {
        if !(1..=MAX_EDGE).contains(&width) || !(1..=MAX_EDGE).contains(&height) {
            return Err(Unavailable(format!(
                "a picture is 1 to {MAX_EDGE} pixels each way, not {width} × {height}"
            )));
        }
        if !camera.is_valid() {
            return Err(Unavailable(
                "the camera must be finite, off its target, and not look straight up or down"
                    .into(),
            ));
        }
        let transform = camera.view_projection(f64::from(width) / f64::from(height));
        let to_light = light::view_projection(camera);
        let vertices: Vec<GpuVertex> = meshes
            .iter()
            .flat_map(|m| &m.vertices)
            .map(|v| {
                let clip = transform * v.position.extend(1.0);
                let n: DVec3 = v.normal;
                // Solid, shaded things cast shadows; translucent walls, lines and overlays
                // do not.
                let casts = self.depth_cues && v.colour[3] >= 1.0 && n != DVec3::ZERO;
                GpuVertex {
                    clip: clip.to_array().map(|c| c as f32),
                    normal: n.to_array().map(|c| c as f32),
                    colour: v.colour,
                    light: if casts {
                        (to_light * v.position.extend(1.0))
                            .to_array()
                            .map(|c| c as f32)
                    } else {
                        NO_SHADOW
                    },
                }
            })
            .collect();
        // Allocating a frame's images costs more than drawing into them: keep them.
        let fits =
            |f: &Frame| (f.width, f.height) == (width, height) && f.capacity >= vertices.len();
        let mut frame = match self.frame.take() {
            Some(frame) if fits(&frame) => frame,
            old => {
                if let Some(old) = old {
                    old.destroy(self);
                }
                // Room for growth, so a scene gaining a few vertices keeps its buffer.
                Frame::new(self, width, height, (vertices.len() * 2).max(1024))?
            }
        };
        let result = frame.draw(self, &vertices, background);
        self.frame = Some(frame);
        result
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // SAFETY: no frame is in flight (draw waits for its own); objects die in reverse.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Some(frame) = self.frame.take() {
                frame.destroy(self);
            }
            self.device.destroy_pipeline(self.pipeline, None);
            self.device.destroy_pipeline(self.shadow_pipeline, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device.destroy_sampler(self.sampler, None);
            self.device.destroy_descriptor_pool(self.descriptors, None);
            self.device
                .destroy_descriptor_set_layout(self.set_layout, None);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            self.instance.destroy_instance(None);
        }
    }
}
