/* Clarke and Park transforms (amplitude-invariant), three phases. */
#ifndef FS_TRANSFORMS_H
#define FS_TRANSFORMS_H

typedef struct { float alpha; float beta; } fs_ab;
typedef struct { float d; float q; } fs_dq;

/* Amplitude-invariant Clarke of a three-phase set; the zero sequence is dropped. */
fs_ab fs_clarke(float x_a, float x_b, float x_c);
/* Inverse Clarke: phase values with zero zero-sequence. */
void fs_inv_clarke(fs_ab x, float x_abc[3]);
/* Park: stationary -> frame at angle theta, given cos(theta), sin(theta). */
fs_dq fs_park(fs_ab x, float cos_theta, float sin_theta);
/* Inverse Park: frame at angle theta -> stationary. */
fs_ab fs_inv_park(fs_dq x, float cos_theta, float sin_theta);

#endif /* FS_TRANSFORMS_H */
