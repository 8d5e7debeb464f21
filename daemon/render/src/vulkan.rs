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
use crate::smoothing;

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

/// The images and buffers of one frame.
struct Frame {
    /// The picture.
    colour: (vk::Image, Allocation, vk::ImageView),
    depth: (vk::Image, Allocation, vk::ImageView),
    /// What the light sees first.
    shadow: (vk::Image, Allocation, vk::ImageView),
    vertices: (vk::Buffer, Allocation),
    readback: (vk::Buffer, Allocation),
    width: u32,
    height: u32,
    /// Vertices the vertex buffer holds.
    capacity: usize,
}

impl Frame {
    fn image(
        r: &Renderer,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
        (width, height): (u32, u32),
    ) -> Result<(vk::Image, Allocation, vk::ImageView), Unavailable> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let d = &r.device;
        // SAFETY: valid create infos; everything is destroyed in `destroy`.
        unsafe {
            let image = d
                .create_image(&info, None)
                .map_err(failed("creating an image"))?;
            let memory = r.allocate(
                d.get_image_memory_requirements(image),
                vk::MemoryPropertyFlags::DEVICE_LOCAL,
            )?;
            d.bind_image_memory(image, memory.memory, 0)
                .map_err(failed("binding image memory"))?;
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(range(aspect));
            let view = d
                .create_image_view(&view_info, None)
                .map_err(failed("creating a view"))?;
            Ok((image, memory, view))
        }
    }

    fn buffer(
        r: &Renderer,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<(vk::Buffer, Allocation), Unavailable> {
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        let d = &r.device;
        // SAFETY: valid create info; destroyed in `destroy`.
        unsafe {
            let buffer = d
                .create_buffer(&info, None)
                .map_err(failed("creating a buffer"))?;
            let memory = r.allocate(
                d.get_buffer_memory_requirements(buffer),
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
            )?;
            d.bind_buffer_memory(buffer, memory.memory, 0)
                .map_err(failed("binding buffer memory"))?;
            Ok((buffer, memory))
        }
    }

    fn new(r: &Renderer, width: u32, height: u32, vertices: usize) -> Result<Self, Unavailable> {
        let frame = Self {
            colour: Self::image(
                r,
                COLOUR,
                vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                vk::ImageAspectFlags::COLOR,
                (width, height),
            )?,
            depth: Self::image(
                r,
                DEPTH,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                vk::ImageAspectFlags::DEPTH,
                (width, height),
            )?,
            shadow: Self::image(
                r,
                DEPTH,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
                vk::ImageAspectFlags::DEPTH,
                (SHADOW_EDGE, SHADOW_EDGE),
            )?,
            vertices: Self::buffer(
                r,
                (vertices * std::mem::size_of::<GpuVertex>()) as u64,
                vk::BufferUsageFlags::VERTEX_BUFFER,
            )?,
            readback: Self::buffer(
                r,
                u64::from(width) * u64::from(height) * 4,
                vk::BufferUsageFlags::TRANSFER_DST,
            )?,
            width,
            height,
            capacity: vertices,
        };
        // The one set points at this frame's shadow map (the last frame's is gone).
        let image = [vk::DescriptorImageInfo::default()
            .image_view(frame.shadow.2)
            .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
        let sampler = [vk::DescriptorImageInfo::default().sampler(r.sampler)];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(r.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&image),
            vk::WriteDescriptorSet::default()
                .dst_set(r.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&sampler),
        ];
        // SAFETY: no frame is in flight; the view and sampler outlive the set's use.
        unsafe { r.device.update_descriptor_sets(&writes, &[]) };
        Ok(frame)
    }

    fn draw(
        &mut self,
        r: &Renderer,
        vertices: &[GpuVertex],
        background: [f32; 4],
    ) -> Result<Picture, Unavailable> {
        // SAFETY: the buffers and images belong to this frame and the device; the command
        // buffer is recorded, submitted and waited for before anything is read or freed.
        unsafe {
            self.upload(&r.device, vertices)?;
            let cmd = Self::begin_commands(r)?;
            // The light's view first, into the shadow map; then the camera's, reading it.
            self.record_shadow(r, cmd, vertices);
            self.record_camera(r, cmd, vertices, background);
            self.record_readback(&r.device, cmd);
            Self::submit_and_wait(r, cmd)?;
            self.read_back(r)
        }
    }

    /// Copy `vertices` into the vertex buffer.
    ///
    /// # Safety
    /// No work of this frame is in flight, and the buffer holds `vertices`.
    unsafe fn upload(&self, d: &ash::Device, vertices: &[GpuVertex]) -> Result<(), Unavailable> {
        if !vertices.is_empty() {
            let size = std::mem::size_of_val(vertices);
            // SAFETY: as the caller promises; the mapping is `size` bytes long.
            unsafe {
                let to = d
                    .map_memory(
                        self.vertices.1.memory,
                        0,
                        size as u64,
                        vk::MemoryMapFlags::empty(),
                    )
                    .map_err(failed("mapping the vertices"))?;
                std::ptr::copy_nonoverlapping(
                    vertices.as_ptr().cast::<u8>(),
                    to.cast::<u8>(),
                    size,
                );
                d.unmap_memory(self.vertices.1.memory);
            }
        }
        Ok(())
    }

    /// A command buffer from the renderer's pool, recording once.
    fn begin_commands(r: &Renderer) -> Result<vk::CommandBuffer, Unavailable> {
        let d = &r.device;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(r.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid infos for the renderer's own pool; the buffer is freed once submitted.
        unsafe {
            let cmd = d
                .allocate_command_buffers(&alloc)
                .map_err(failed("allocating commands"))?[0];
            d.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .map_err(failed("recording"))?;
            Ok(cmd)
        }
    }

    /// Record the light's view of `vertices` into the shadow map.
    ///
    /// # Safety
    /// `cmd` is recording, from `r`'s pool, and the vertex buffer holds `vertices`.
    unsafe fn record_shadow(&self, r: &Renderer, cmd: vk::CommandBuffer, vertices: &[GpuVertex]) {
        let d = &r.device;
        // SAFETY: as the caller promises; the shadow map belongs to this frame.
        unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(
                    self.shadow.0,
                    vk::ImageAspectFlags::DEPTH,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                )],
            );
            let shadow_depth = vk::RenderingAttachmentInfo::default()
                .image_view(self.shadow.2)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(CLEAR_DEPTH);
            let shadow_area = whole(SHADOW_EDGE, SHADOW_EDGE);
            d.cmd_begin_rendering(
                cmd,
                &vk::RenderingInfo::default()
                    .render_area(shadow_area)
                    .layer_count(1)
                    .depth_attachment(&shadow_depth),
            );
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, r.shadow_pipeline);
            d.cmd_set_viewport(cmd, 0, &[viewport(SHADOW_EDGE, SHADOW_EDGE)]);
            d.cmd_set_scissor(cmd, 0, &[shadow_area]);
            if !vertices.is_empty() {
                d.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.0], &[0]);
                d.cmd_draw(cmd, vertices.len() as u32, 1, 0, 0);
            }
            d.cmd_end_rendering(cmd);
        }
    }

    /// Record the camera's view of `vertices` over `background`, reading the shadow map.
    ///
    /// # Safety
    /// As [`Frame::record_shadow`], which has been recorded first.
    unsafe fn record_camera(
        &self,
        r: &Renderer,
        cmd: vk::CommandBuffer,
        vertices: &[GpuVertex],
        background: [f32; 4],
    ) {
        let d = &r.device;
        // SAFETY: as the caller promises; the images belong to this frame.
        unsafe {
            self.camera_barrier(d, cmd);
            let colour = [vk::RenderingAttachmentInfo::default()
                .image_view(self.colour.2)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue {
                        float32: background,
                    },
                })];
            let depth = vk::RenderingAttachmentInfo::default()
                .image_view(self.depth.2)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(CLEAR_DEPTH);
            let area = whole(self.width, self.height);
            d.cmd_begin_rendering(
                cmd,
                &vk::RenderingInfo::default()
                    .render_area(area)
                    .layer_count(1)
                    .color_attachments(&colour)
                    .depth_attachment(&depth),
            );
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, r.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                r.layout,
                0,
                &[r.set],
                &[],
            );
            d.cmd_set_viewport(cmd, 0, &[viewport(self.width, self.height)]);
            d.cmd_set_scissor(cmd, 0, &[area]);
            if !vertices.is_empty() {
                d.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.0], &[0]);
                d.cmd_draw(cmd, vertices.len() as u32, 1, 0, 0);
            }
            d.cmd_end_rendering(cmd);
        }
    }

    /// Record the barrier before the camera's view: shadow map readable, picture writable.
    ///
    /// # Safety
    /// `cmd` is recording, on device `d`.
    unsafe fn camera_barrier(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        // SAFETY: as the caller promises; the images belong to this frame.
        unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::FRAGMENT_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[
                    barrier(
                        self.shadow.0,
                        vk::ImageAspectFlags::DEPTH,
                        vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                        vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                        vk::AccessFlags::SHADER_READ,
                    ),
                    barrier(
                        self.colour.0,
                        vk::ImageAspectFlags::COLOR,
                        vk::ImageLayout::UNDEFINED,
                        vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                        vk::AccessFlags::empty(),
                        vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    ),
                    barrier(
                        self.depth.0,
                        vk::ImageAspectFlags::DEPTH,
                        vk::ImageLayout::UNDEFINED,
                        vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                        vk::AccessFlags::empty(),
                        vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                ],
            );
        }
    }

    /// Record the copy of the picture into the readback buffer.
    ///
    /// # Safety
    /// `cmd` is recording, on device `d`, after the camera's view.
    unsafe fn record_readback(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        // SAFETY: as the caller promises; the picture and buffer belong to this frame.
        unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(
                    self.colour.0,
                    vk::ImageAspectFlags::COLOR,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    vk::AccessFlags::TRANSFER_READ,
                )],
            );
            let copy = vk::BufferImageCopy::default()
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D {
                    width: self.width,
                    height: self.height,
                    depth: 1,
                });
            d.cmd_copy_image_to_buffer(
                cmd,
                self.colour.0,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.readback.0,
                &[copy],
            );
        }
    }

    /// End `cmd`, run it and wait until it is done, then free it.
    ///
    /// # Safety
    /// `cmd` is recording, from `r`'s pool, and everything it uses lives until it is done.
    unsafe fn submit_and_wait(r: &Renderer, cmd: vk::CommandBuffer) -> Result<(), Unavailable> {
        let d = &r.device;
        // SAFETY: as the caller promises; the fence is waited for before it is destroyed.
        unsafe {
            d.end_command_buffer(cmd).map_err(failed("recording"))?;
            let fence = d
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(failed("creating a fence"))?;
            let commands = [cmd];
            let submitted = d
                .queue_submit(
                    r.queue,
                    &[vk::SubmitInfo::default().command_buffers(&commands)],
                    fence,
                )
                .and_then(|()| d.wait_for_fences(&[fence], true, u64::MAX));
            d.destroy_fence(fence, None);
            d.free_command_buffers(r.pool, &commands);
            submitted.map_err(failed("drawing"))
        }
    }

    /// The picture in the readback buffer, its edges smoothed if `r` draws depth cues.
    ///
    /// # Safety
    /// The copy into the readback buffer has completed.
    unsafe fn read_back(&self, r: &Renderer) -> Result<Picture, Unavailable> {
        let d = &r.device;
        let (width, height) = (self.width, self.height);
        let size = u64::from(width) * u64::from(height) * 4;
        // SAFETY: as the caller promises; the buffer holds `size` bytes.
        unsafe {
            let from = d
                .map_memory(self.readback.1.memory, 0, size, vk::MemoryMapFlags::empty())
                .map_err(failed("mapping the picture"))?;
            let pixels = std::slice::from_raw_parts(from.cast::<u8>(), size as usize);
            let rgba = if r.depth_cues {
                smoothing::smooth_edges(pixels, width as usize, height as usize)
            } else {
                pixels.to_vec()
            };
            d.unmap_memory(self.readback.1.memory);
            Ok(Picture {
                width,
                height,
                rgba,
            })
        }
    }

    fn destroy(self, r: &Renderer) {
        let d = &r.device;
        // SAFETY: the frame's work has completed (or was never submitted).
        unsafe {
            for (image, memory, view) in [self.colour, self.depth, self.shadow] {
                d.destroy_image_view(view, None);
                d.destroy_image(image, None);
                d.free_memory(memory.memory, None);
            }
            for (buffer, memory) in [self.vertices, self.readback] {
                d.destroy_buffer(buffer, None);
                d.free_memory(memory.memory, None);
            }
        }
    }
}

fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(aspect)
        .level_count(1)
        .layer_count(1)
}

/// A barrier moving all of `image` from layout `old` to `new`.
fn barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src_access: vk::AccessFlags,
    dst_access: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .image(image)
        .subresource_range(range(aspect))
        .old_layout(old)
        .new_layout(new)
        .src_access_mask(src_access)
        .dst_access_mask(dst_access)
}

/// The whole of a `width × height` image.
fn whole(width: u32, height: u32) -> vk::Rect2D {
    vk::Rect2D {
        offset: vk::Offset2D { x: 0, y: 0 },
        extent: vk::Extent2D { width, height },
    }
}

/// The viewport covering a `width × height` image, over the full depth range.
fn viewport(width: u32, height: u32) -> vk::Viewport {
    vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: width as f32,
        height: height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
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
