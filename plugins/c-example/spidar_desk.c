/*
 * spidar-desk: a mechanism plugin written in C, to show that the hapticd plugin ABI is
 * language-neutral. A desktop SPIDAR: one finger cap (point grip, 3 DOF) held by four
 * strings from alternate corners of a 0.30 m cube.
 *
 * Build: cc -shared -fPIC -O2 $(pkg-config --cflags hapticd-plugin) spidar_desk.c -o libspidar_desk.so
 *   (from the repository without hapticd installed: -I plugin-api/include)
 */
#include <string.h>

#include "hapticd_plugin.h"

#define HALF_EDGE 0.15 /* metres */
#define STRINGS 4

static const double corners[STRINGS][3] = {
    {-1.0, 1.0, 1.0},
    {1.0, 1.0, -1.0},
    {-1.0, -1.0, -1.0},
    {1.0, -1.0, 1.0},
};

static const HapticdHost *host;

static void log_info(const char *message) {
    if (host && host->log) {
        host->log(host->context, HAPTICD_LOG_INFO, message, strlen(message));
    }
}

/* [main] */
static int32_t info(HapticdMechanismInfo *out) {
    if (!out) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    out->effector_count = 1;
    out->string_count = STRINGS;
    out->lambda = 0.01;
    out->torque_weight = 1.0;
    log_info("described a 4-string desktop SPIDAR");
    return HAPTICD_OK;
}

/* [main] */
static int32_t effector(uint32_t index, HapticdEffector *out) {
    if (!out || index != 0) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    memset(out, 0, sizeof *out);
    strncpy(out->name, "finger", HAPTICD_NAME_CAPACITY - 1);
    out->dof = 3;
    out->calibration_orientation[0] = 1.0;
    return HAPTICD_OK;
}

/* [main] */
static int32_t string(uint32_t index, HapticdString *out) {
    if (!out || index >= STRINGS) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    memset(out, 0, sizeof *out);
    out->effector = 0;
    for (int axis = 0; axis < 3; axis++) {
        out->motor[axis] = corners[index][axis] * HALF_EDGE;
    }
    out->metres_per_pulse = 2.513e-5; /* 8 mm pulley, 2000 counts per turn */
    out->volts_per_newton = 0.3653;
    out->tension_min = 0.3;
    out->tension_max = 6.0;
    return HAPTICD_OK;
}

static const HapticdMechanismVtable vtable = {
    .struct_size = sizeof(HapticdMechanismVtable),
    .info = info,
    .effector = effector,
    .string = string,
};

static const HapticdPluginDescriptor descriptor = {
    .abi_major = HAPTICD_ABI_MAJOR,
    .abi_minor = HAPTICD_ABI_MINOR,
    .kind = HAPTICD_KIND_MECHANISM,
    .name = "spidar-desk",
    .version = "1.0.0",
    .description = "Desktop SPIDAR in C: 4 strings from a 0.30 m cube to one finger cap",
    .mechanism = &vtable,
    .scene = NULL,
};

/* [main] */
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {
    if (h && h->abi_major != HAPTICD_ABI_MAJOR) {
        return NULL;
    }
    host = h;
    return &descriptor;
}
