// ordered.h: floats reduced with integer atomics (OpenCL 1.2 has atomic_min/atomic_max on ints only).
// ordered_int(v) is an int whose order is the floats' order (negative floats' bits reversed), so atomic_min/max of
// ordered ints is min/max of the floats; the mapping is its own inverse (host: ugpcl.buffers.ordered_floats).
// The host fills the target with INT_MAX (for a minimum) or INT_MIN (for a maximum) before the launch.
#ifndef UGPCL_ORDERED_H
#define UGPCL_ORDERED_H

inline int ordered_int(float v) {
    const int i = as_int(v);
    return i >= 0 ? i : i ^ 0x7fffffff;
}

inline float ordered_float(int i) { return as_float(i >= 0 ? i : i ^ 0x7fffffff); }  // ordered_int's inverse

#endif
