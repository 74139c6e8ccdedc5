/*
 * heading.c: one raw DoFP frame through the bpins compass, from C.
 *
 * The frame is a file of raw little-endian uint16 samples, row after row (what a
 * camera SDK's buffer holds). `f000.u16` beside this file is the clean sample's frame
 * 0 so (samples/clean; `tests/c_example.rs` in crates/bpins-capi checks it is). The
 * camera, the sun and the attitude come as arguments:
 *
 *   heading FRAME.u16 WIDTH_PX HEIGHT_PX BIT_DEPTH BLACK_LEVEL_DN FOCAL_PX CX_PX CY_PX
 *           SUN_AZIMUTH_DEG SUN_ELEVATION_DEG [TILT_X_DEG TILT_Y_DEG TILT_SIGMA_DEG
 *           [CALIBRATION.toml]]
 *
 * Build (from the repository root, after `cargo build --release -p bpins-capi`):
 *
 *   cc -std=c99 -O2 -Icrates/bpins-capi/include examples/c/heading.c \
 *      target/release/libbpins.a -lpthread -ldl -lm -o heading
 *
 * and run it on the shipped frame (examples/c/run.sh does all three steps):
 *
 *   ./heading examples/c/f000.u16 612 512 12 64 579.7101449275362 305.5 255.5 40 25 0 0 0
 *
 * It prints the heading with its 1σ, or why the frame has none; on an error it prints
 * bpins's message and exits with status 1.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#include "bpins.h"

/* A number from argv, or exit naming the argument. */
static double number(const char *text, const char *name) {
    char *end = NULL;
    errno = 0;
    double v = strtod(text, &end);
    if (errno != 0 || end == text || *end != '\0') {
        fprintf(stderr, "heading: %s: `%s` is not a number\n", name, text);
        exit(2);
    }
    return v;
}

/* The whole file as little-endian uint16 samples; *count is their number. */
static uint16_t *read_u16(const char *path, size_t *count) {
    FILE *f = fopen(path, "rb");
    if (f == NULL || fseek(f, 0, SEEK_END) != 0) {
        perror(path);
        if (f != NULL) fclose(f);
        return NULL;
    }
    long size = ftell(f);
    rewind(f);
    unsigned char *bytes = size > 0 ? malloc((size_t)size) : NULL;
    if (bytes == NULL || fread(bytes, 1, (size_t)size, f) != (size_t)size) {
        fprintf(stderr, "%s: cannot read %ld bytes\n", path, size);
        free(bytes);
        fclose(f);
        return NULL;
    }
    fclose(f);
    *count = (size_t)size / 2;
    uint16_t *samples = malloc(*count * sizeof *samples);
    for (size_t i = 0; samples != NULL && i < *count; i++) {
        samples[i] = (uint16_t)(bytes[2 * i] | (bytes[2 * i + 1] << 8));
    }
    free(bytes);
    return samples;
}

int main(int argc, char **argv) {
    if (argc != 11 && argc != 14 && argc != 15) {
        fprintf(stderr,
                "usage: %s FRAME.u16 WIDTH_PX HEIGHT_PX BIT_DEPTH BLACK_LEVEL_DN FOCAL_PX CX_PX CY_PX "
                "SUN_AZIMUTH_DEG SUN_ELEVATION_DEG [TILT_X_DEG TILT_Y_DEG TILT_SIGMA_DEG [CALIBRATION.toml]]\n",
                argv[0]);
        return 2;
    }

    /* Once: the camera and the sensor (defaults: IMX250MZR mosaic, sun-vector
     * extractor, the estimator's default options), and the calibration if given. */
    BpinsCompassConfig config;
    bpins_compass_config_default(&config);
    config.width_px = (uint32_t)number(argv[2], "WIDTH_PX");
    config.height_px = (uint32_t)number(argv[3], "HEIGHT_PX");
    config.bit_depth = (uint32_t)number(argv[4], "BIT_DEPTH");
    config.black_level_dn = number(argv[5], "BLACK_LEVEL_DN");
    config.projection = BPINS_PROJECTION_PINHOLE;
    config.focal_length_px = number(argv[6], "FOCAL_PX");
    config.cx_px = number(argv[7], "CX_PX");
    config.cy_px = number(argv[8], "CY_PX");
    const char *calibration = argc == 15 ? argv[14] : NULL;

    BpinsCompass *compass = NULL;
    if (bpins_compass_new_with_calibration(&config, calibration, &compass) != BPINS_OK) {
        fprintf(stderr, "heading: %s\n", bpins_last_error_message());
        return 1;
    }

    /* Per frame: the camera's buffer (borrowed, not copied), the sun, the IMU. */
    size_t count = 0;
    uint16_t *frame = read_u16(argv[1], &count);
    if (frame == NULL) {
        bpins_compass_free(compass);
        return 1;
    }
    size_t width = config.width_px, height = config.height_px;
    if (count != width * height) {
        fprintf(stderr, "heading: %s holds %zu samples, not %zu x %zu\n", argv[1], count, width, height);
        free(frame);
        bpins_compass_free(compass);
        return 1;
    }
    BpinsSun sun = {0};
    sun.kind = BPINS_SUN_ANGLES;
    sun.azimuth_deg = number(argv[9], "SUN_AZIMUTH_DEG");
    sun.elevation_deg = number(argv[10], "SUN_ELEVATION_DEG");
    BpinsAttitude attitude = {0};
    if (argc >= 14) {
        attitude.tilt_x_deg = number(argv[11], "TILT_X_DEG");
        attitude.tilt_y_deg = number(argv[12], "TILT_Y_DEG");
        attitude.sigma_deg = number(argv[13], "TILT_SIGMA_DEG");
    }

    BpinsHeading fix;
    BpinsStatus status = bpins_compass_heading_u16(compass, frame, width, height, width, &sun, &attitude, &fix);
    int code = 0;
    if (status != BPINS_OK) {
        fprintf(stderr, "heading: %s\n", bpins_last_error_message());
        code = 1;
    } else if (!fix.has_heading) {
        printf("no heading (reason %d): %s\n", (int)fix.reason, fix.message);
        printf("used_fraction %.4f\n", fix.used_fraction);
    } else {
        printf("bpins %s\n", bpins_version());
        printf("heading_deg %.17g\n", fix.heading_deg);
        printf("sigma_deg %.17g\n", fix.sigma_deg);
        printf("used_fraction %.4f\n", fix.used_fraction);
        printf("residual_rms_deg %.4f\n", fix.residual_rms_deg);
        printf("heading: %.4f deg +- %.4f deg (1 sigma), %.1f %% of the image's cells used\n", fix.heading_deg,
               fix.sigma_deg, 100.0 * fix.used_fraction);
    }
    free(frame);
    bpins_compass_free(compass);
    return code;
}
