/* The gather pass of interleaved sampling (Toth and Umenhoffer 2009, 4.1), shared by C and
 * GLSL: a box filter of M pixels along one image axis, run once across and once down (the
 * filter is separable). Every run of M neighbours holds each interleave phase exactly once,
 * so the average over an M x M window takes all M^2 stratified samples of every segment.
 * At the image's edges the window is shifted inside, keeping M pixels and every phase.
 * Include after vs_common.h. */
#ifndef VS_GATHER_H
#define VS_GATHER_H

/* The gather table: one vec4 (width, height, M, axis: 0 across, 1 down). */
#define VS_GATHER_OFF_PARAMS 0
#define VS_GATHER_SIZE 1

/* The first pixel of the window of M pixels around position i of n. */
VS_FUNC int vs_gather_window_start(int i, int n, int m)
{
    int start = i - m / 2;
    if (start + m > n)
        start = n - m;
    return start > 0 ? start : 0;
}

/* The filtered value of one channel at pixel `item`, from image_in (3 floats per pixel). */
VS_FUNC float vs_gather_channel(VS_DATA_PARAM(vs_vec4, gather_data)
                                    VS_DATA_PARAM(float, image_in) int item,
                                int channel)
{
    int width = VS_INT(gather_data[VS_GATHER_OFF_PARAMS].x);
    int height = VS_INT(gather_data[VS_GATHER_OFF_PARAMS].y);
    int m = VS_INT(gather_data[VS_GATHER_OFF_PARAMS].z);
    int down = VS_INT(gather_data[VS_GATHER_OFF_PARAMS].w);
    int x = item % width, y = item / width;
    int n = down != 0 ? height : width;
    int at = down != 0 ? y : x;
    int taps = m < n ? m : n;
    int start = vs_gather_window_start(at, n, taps);
    float sum = 0.0f;
    for (int k = 0; k < taps; ++k) {
        int p = down != 0 ? (start + k) * width + x : y * width + start + k;
        sum += image_in[3 * p + channel];
    }
    return sum / VS_FLOAT(taps);
}

#endif
