// grass.h: the parameter block of Grass.shader (vol.1 ch.6, docs/chapters/06-grass.md), read by GrassExpand.
// The book's material properties in the order Grass.shader declares them: twelve floats, time, the wind time scale,
// two pads, then the two colours. Every field is 4-byte aligned except the float4s, which sit at offsets 64 and 80:
// 96 bytes, no hidden padding. numpy mirror: ugpcl.scenes.grass.GRASS_PARAMS_DTYPE (a test compares the sizes on the device).
#ifndef UGPCL_GRASS_H
#define UGPCL_GRASS_H

typedef struct {
    float height, width;                                // _Height, _Width
    float bottom_height, middle_height, top_height;     // _BottomHeight, _MiddleHeight, _TopHeight
    float bottom_width, middle_width, top_width;        // _BottomWidth, _MiddleWidth, _TopWidth
    float bottom_bend, middle_bend, top_bend;           // _BottomBend, _MiddleBend, _TopBend
    float wind_power;                                   // _WindPower
    float time;                                         // seconds (Unity's Time.time)
    float wind_time_scale;                              // sin(_Time) keeps only _Time.x = t/20: scale 1/20
    float pad0, pad1;                                   // keep the colours 16-byte aligned
    float4 top_color, bottom_color;                     // _TopColor, _BottomColor (rgba)
} GrassParams;

#endif
