/* Loss-of-lock monitor: tells when a position estimator no longer tracks.
 *
 * The caller forms a residual r from the estimator's own signals, scaled so
 * that r <= 1 while it tracks (fs_drive: the sliding-mode observer's current
 * error over twice its boundary layer and its PLL error over sin 30 deg; the
 * injection estimator's heterodyne error over 15 deg). A tracking estimator
 * leaves r <= 1 only briefly, in transients; one that has lost the rotor
 * keeps it there. The monitor integrates the time r spends above 1, each
 * step weighted by r up to FS_LOCK_R_MAX, leaking it away at one step's time
 * a step below 1, and latches `lost` when that time reaches t_lost. Reset clears it (after a recovery).
 */
#ifndef FS_LOCK_H
#define FS_LOCK_H

#include "fs_types.h"

/* A step's residual counts at most this many steps' time: an estimator
 * twice out of its bound for half of t_lost is as lost as one just out of
 * it for all of it (the SMO-only reversal through zero on motulator's
 * machine: 46 ms more than 90 el.deg off, the residual above 1 for 18 ms
 * at up to 1.7, then the estimator back on its own) */
#define FS_LOCK_R_MAX 2.0f
typedef struct {
    float Ts;        /* s */
    float t_lost;    /* s of residual above 1, net of the time below, that means lost */
} fs_lock_config;

typedef struct {
    fs_lock_config cfg;
    float t_over;    /* s, the leaky integral */
    bool lost;       /* latched */
} fs_lock;

fs_status fs_lock_init(fs_lock *lk, const fs_lock_config *cfg);
void fs_lock_reset(fs_lock *lk);
/* One step with the residual; returns whether lock is lost (latched). */
bool fs_lock_step(fs_lock *lk, float r);
/* Evidence that needs no time: lock is lost now (latched). */
void fs_lock_latch(fs_lock *lk);

#endif /* FS_LOCK_H */
