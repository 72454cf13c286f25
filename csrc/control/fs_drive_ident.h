/* The drive's identification mode (FS_MODE_IDENTIFY): the glue between the
 * hub (fs_drive.c) and the sequence (fs_ident.h). Internal, not in the cdef. */
#ifndef FS_DRIVE_IDENT_H
#define FS_DRIVE_IDENT_H

#include "fs_drive.h"

/* Checks what the mode needs (three phases, the inverter, Ts, T_pwm, delay,
 * pole_pairs, i_max, the ident block) and starts the sequence. */
fs_status fs_drive_ident_init(fs_drive *drv, const fs_drive_config *cfg);
/* One step: the sequence's voltage, modulated without dead-time
 * compensation (the sequence measures the inverter's error itself). */
void fs_drive_ident_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out);

#endif /* FS_DRIVE_IDENT_H */
