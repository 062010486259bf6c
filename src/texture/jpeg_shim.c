/* JPEG decoding through libjpeg-turbo's decoder, as Mitsuba 3 decodes:
 * library defaults (islow IDCT, fancy chroma upsampling, the library's
 * fixed-point YCbCr -> RGB). The library is the copy vendored in the
 * mozjpeg-sys crate, linked statically; build.rs compiles this file against
 * that copy's jpeglib.h and generated jconfig.h (DEP_JPEG_INCLUDE), not a
 * system libjpeg. Errors longjmp back here and are returned with a message,
 * never unwound through Rust. See src/texture/jpeg.rs. */
#include <setjmp.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>

struct ltc_jpeg_error {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
    char *msg;
    size_t msg_len;
};

static void ltc_jpeg_error_exit(j_common_ptr cinfo) {
    struct ltc_jpeg_error *err = (struct ltc_jpeg_error *) cinfo->err;
    char buf[JMSG_LENGTH_MAX];
    (*cinfo->err->format_message)(cinfo, buf);
    if (err->msg_len > 0) {
        strncpy(err->msg, buf, err->msg_len - 1);
        err->msg[err->msg_len - 1] = '\0';
    }
    longjmp(err->jump, 1);
}

/* Warnings (e.g. corrupt data that the library recovers from) are ignored,
 * as with the library's default handler apart from printing. */
static void ltc_jpeg_output_message(j_common_ptr cinfo) { (void) cinfo; }

/* Decodes `len` bytes into a newly malloc'ed buffer of rows (top first) of
 * `*components` (1 or 3) bytes per pixel. Returns 0 on success; otherwise
 * nonzero with a message in `msg`. */
int ltc_jpeg_decode(const unsigned char *data, size_t len, unsigned char **out,
                    unsigned *width, unsigned *height, int *components,
                    char *msg, size_t msg_len) {
    struct jpeg_decompress_struct cinfo;
    struct ltc_jpeg_error err;
    unsigned char *volatile buf = NULL;

    *out = NULL;
    memset(&cinfo, 0, sizeof(cinfo));
    cinfo.err = jpeg_std_error(&err.mgr);
    err.mgr.error_exit = ltc_jpeg_error_exit;
    err.mgr.output_message = ltc_jpeg_output_message;
    err.msg = msg;
    err.msg_len = msg_len;
    if (setjmp(err.jump)) {
        jpeg_destroy_decompress(&cinfo);
        free(buf);
        return 1;
    }
    jpeg_create_decompress(&cinfo);
    jpeg_mem_src(&cinfo, data, (unsigned long) len);
    jpeg_read_header(&cinfo, TRUE);
    jpeg_start_decompress(&cinfo);
    if (cinfo.output_components != 1 && cinfo.output_components != 3) {
        snprintf(msg, msg_len, "unsupported number of components: %d",
                 cinfo.output_components);
        jpeg_destroy_decompress(&cinfo);
        return 2;
    }
    size_t stride = (size_t) cinfo.output_width * (size_t) cinfo.output_components;
    buf = (unsigned char *) malloc(stride * (size_t) cinfo.output_height);
    if (!buf) {
        snprintf(msg, msg_len, "out of memory");
        jpeg_destroy_decompress(&cinfo);
        return 3;
    }
    while (cinfo.output_scanline < cinfo.output_height) {
        JSAMPROW row = buf + stride * (size_t) cinfo.output_scanline;
        jpeg_read_scanlines(&cinfo, &row, 1);
    }
    jpeg_finish_decompress(&cinfo);
    *width = cinfo.output_width;
    *height = cinfo.output_height;
    *components = cinfo.output_components;
    jpeg_destroy_decompress(&cinfo);
    *out = buf;
    return 0;
}

void ltc_jpeg_free(unsigned char *p) { free(p); }
