/*
 * floor: a scene plugin written in C, the smallest complete example of the scene ABI.
 * A direct scene: inside every haptic tick it pushes each pointer out of a floor at
 * y = -0.03 m with a spring and a damper (penalty rendering), and touches nothing else.
 *
 * Build against an installed hapticd:
 *   cc -shared -fPIC -O2 $(pkg-config --cflags hapticd-plugin) floor_scene.c -o libfloor_scene.so
 * Run: hapticd --scene ./libfloor_scene.so (the plugin file must be owned by root or by
 * hapticd's user and not writable by others).
 */
#include <stdlib.h>
#include <string.h>

#include "hapticd_plugin.h"

#define FLOOR_Y -0.03    /* metres */
#define STIFFNESS 1000.0 /* N/m */
#define DAMPING 2.0      /* N·s/m, only while pressing in */

struct floor {
    uint32_t pointer_count;
};

/* [main] The scene file is ignored: this floor has no settings. */
static int32_t create(const char *path, uint32_t pointer_count, void **instance,
                      HapticdSceneInfo *info) {
    (void)path;
    if (!instance || !info) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    /* Allocation is fine here, on the main thread; never in step_direct. */
    struct floor *f = malloc(sizeof *f);
    if (!f) {
        return HAPTICD_ERROR_FAILED;
    }
    f->pointer_count = pointer_count;
    *instance = f;
    info->style = HAPTICD_SCENE_DIRECT;
    info->physics_rate = 0.0;
    return HAPTICD_OK;
}

/* [main] */
static void destroy(void *instance) { free(instance); }

/* [rt] No allocation, lock, log or blocking call: this runs inside the haptic tick. */
static int32_t step_direct(void *instance, double dt, const HapticdPointer *pointers,
                           uint32_t pointer_count, HapticdWrench *wrenches) {
    const struct floor *f = instance;
    (void)dt;
    if (!f || !pointers || !wrenches || pointer_count != f->pointer_count) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    for (uint32_t i = 0; i < pointer_count; i++) {
        memset(&wrenches[i], 0, sizeof wrenches[i]);
        double depth = FLOOR_Y - pointers[i].position[1];
        if (depth > 0.0) {
            double push = STIFFNESS * depth;
            double vy = pointers[i].velocity[1];
            if (vy < 0.0) {
                push -= DAMPING * vy;
            }
            wrenches[i].force[1] = push;
        }
    }
    return HAPTICD_OK;
}

/* [main] The extension HAPTICD_EXT_SCENE_GEOMETRY: what the floor looks like, for
 * pictures. One plane of no body (it never moves), drawn 60 cm across. */
static int32_t geometry_counts(void *instance, HapticdGeometryCounts *out) {
    (void)instance;
    if (!out) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    out->bodies = 0;
    out->solids = 1;
    out->triangles = 0;
    return HAPTICD_OK;
}

static int32_t geometry_solid(void *instance, uint32_t index, HapticdSolid *out) {
    (void)instance;
    if (!out || index != 0) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    memset(out, 0, sizeof *out);
    out->body = HAPTICD_NO_BODY;
    out->shape = HAPTICD_SHAPE_PLANE;
    out->flags = HAPTICD_SOLID_FIXED;
    out->size[0] = 0.6;
    out->offset.position[1] = FLOOR_Y;
    out->offset.orientation[0] = 1.0;
    return HAPTICD_OK;
}

static int32_t geometry_triangles(void *instance, uint32_t first, uint32_t count,
                                  HapticdTriangle *out) {
    (void)instance;
    (void)first;
    (void)out;
    return count == 0 ? HAPTICD_OK : HAPTICD_ERROR_ARGUMENT;
}

static const HapticdSceneGeometry geometry = {
    .struct_size = sizeof(HapticdSceneGeometry),
    .counts = geometry_counts,
    .solid = geometry_solid,
    .triangles = geometry_triangles,
};

/* [any] Extensions are found by name: an older host never asks, a newer one gets null for
 * names this plugin does not know. */
static const void *get_extension(const char *id) {
    if (id && strcmp(id, HAPTICD_EXT_SCENE_GEOMETRY) == 0) {
        return &geometry;
    }
    return NULL;
}

static const HapticdSceneVtable vtable = {
    .struct_size = sizeof(HapticdSceneVtable),
    .create = create,
    .destroy = destroy,
    .step_direct = step_direct,
    .step_physics = NULL,
    .get_extension = get_extension,
};

static const HapticdPluginDescriptor descriptor = {
    .abi_major = HAPTICD_ABI_MAJOR,
    .abi_minor = HAPTICD_ABI_MINOR,
    .kind = HAPTICD_KIND_SCENE,
    .name = "floor",
    .version = "1.0.0",
    .description = "A spring floor at y = -0.03 m, in C",
    .mechanism = NULL,
    .scene = &vtable,
};

/* [main] */
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {
    if (h && h->abi_major != HAPTICD_ABI_MAJOR) {
        return NULL;
    }
    return &descriptor;
}
