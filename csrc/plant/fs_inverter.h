/* Two-level three-phase voltage-source inverter (double), for simulation.
 *
 * The carrier is center-aligned: it falls from its peak (1) to its valley (0)
 * in the first half of a period and rises back in the second. A pole is
 * high while the carrier is below its duty, so every period starts and ends
 * at the peak in the zero vector where the currents are sampled.
 *
 * AVERAGED  the pole voltage is its mean over the period: (d - 1/2) u_dc,
 *           less the mean dead-time error sign(i) t_dead/T_pwm u_dc (when the
 *           pole switches), less the device drop sign(i) u_on.
 * SWITCHING each half period is cut at the commanded edges and at the ends of
 *           the dead times; in a dead time both devices are off and a diode
 *           carries the current, so the pole sits on the rail opposite to the
 *           current's sign. Each constant segment is integrated on its own.
 */
#ifndef FS_INVERTER_H
#define FS_INVERTER_H

typedef enum { FS_INV_AVERAGED = 0, FS_INV_SWITCHING = 1 } fs_inverter_kind;

typedef struct {
    int kind;          /* fs_inverter_kind */
    double u_dc;       /* dc-link voltage, V */
    double T_pwm;      /* carrier period, s */
    double t_dead;     /* dead time, s */
    double u_on;       /* device on-state drop, V */
} fs_inverter_config;

enum { FS_INV_MAX_SEG = 7 };

/* A half period as constant-voltage segments. */
typedef struct {
    int n;
    double dt[FS_INV_MAX_SEG];       /* segment lengths, s */
    int state[FS_INV_MAX_SEG][3];    /* per phase: 1 high, 0 low, -1 both off */
} fs_inv_segments;

/* Segments of half period `half` (0: carrier falling, 1: rising). */
void fs_inverter_segments(const fs_inverter_config *c, const double duty[3], int half,
                          fs_inv_segments *seg);
/* Stationary-frame terminal voltage of a segment's switch states given the
 * phase currents (for diodes and device drops). */
void fs_inverter_voltage(const fs_inverter_config *c, const int state[3], const double i_abc[3],
                         double *u_alpha, double *u_beta);
/* Averaged model: mean stationary voltage over the period. */
void fs_inverter_mean_voltage(const fs_inverter_config *c, const double duty[3],
                              const double i_abc[3], double *u_alpha, double *u_beta);

#endif /* FS_INVERTER_H */
