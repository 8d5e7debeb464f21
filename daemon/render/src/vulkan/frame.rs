//! One frame's images and buffers, and the commands that draw into them: the light's view
//! into the shadow map, the camera's, and the read-back.

use ash::vk;

use super::{
    Allocation, CLEAR_DEPTH, COLOUR, DEPTH, GpuVertex, Renderer, SHADOW_EDGE, Unavailable, failed,
};
use crate::picture::Picture;
use crate::smoothing;

/// The images and buffers of one frame.
pub(super) struct Frame {
    /// The picture.
    colour: (vk::Image, Allocation, vk::ImageView),
    depth: (vk::Image, Allocation, vk::ImageView),
    /// What the light sees first.
    shadow: (vk::Image, Allocation, vk::ImageView),
    vertices: (vk::Buffer, Allocation),
    readback: (vk::Buffer, Allocation),
    pub(super) width: u32,
    pub(super) height: u32,
    /// Vertices the vertex buffer holds.
    pub(super) capacity: usize,
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

    pub(super) fn new(
        r: &Renderer,
        width: u32,
        height: u32,
        vertices: usize,
    ) -> Result<Self, Unavailable> {
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

    pub(super) fn draw(
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

    pub(super) fn destroy(self, r: &Renderer) {
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
