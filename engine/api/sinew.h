/*
 * sinew.h - the C API of Sinew, rigid/deformable multi-physics middleware for games.
 *
 * C99, no C++ in this header. Only sinew_-prefixed symbols are exported from libsinew.so.
 * The full API (worlds, bodies, joints, events) grows with issue 4; this is its first entry point.
 */
#ifndef SINEW_H
#define SINEW_H

#if defined(_WIN32)
#define SINEW_API __declspec(dllexport)
#else
#define SINEW_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** Library version as "MAJOR.MINOR.PATCH (float|double)"; a static string, never NULL. */
SINEW_API const char* sinew_version(void);

#ifdef __cplusplus
}
#endif

#endif /* SINEW_H */
