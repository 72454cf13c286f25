/* fs-test-sources: control/fs_fw.c control/fs_status.c
 *
 * fs_fw (zou2021 eqs. (28)-(31)): init refuses each bad field; beta is
 * eq. (31) times the gain; a constant voltage excess gives the exact ZOH
 * first-order response towards -beta w_e L dv_q; the sign works in both
 * directions of rotation and never gives positive d-current; the output is
 * limited to -i_max; with the excess gone it returns to zero by itself
 * (the point of the low-pass in place of the integrator).
 */
#include "control/fs_fw.h"
#include "tests/fs_test.h"

static fs_fw_config base(void)
{
    fs_fw_config c = {1.25e-4f, 0.036f, 942.0f, 1.0f, 2000.0f, 9.0f};
    return c;
}

static void test_init(void)
{
    fs_fw fw;
    fs_fw_config c = base();
    FS_CHECK(fs_fw_init(&fw, &c) == FS_OK, "valid config");
    FS_CHECK_NEAR(fw.beta, 1.0 / (942.0 * 0.036 * 942.0 * 0.036), 1e-6 * fw.beta, "eq. (31)");
    c = base(); c.Ts = 0.0f;        FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_TS, "Ts");
    c = base(); c.L = -1e-3f;       FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_LD, "L");
    c = base(); c.w_e_max = 0.0f;   FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_LIMIT, "w_e_max");
    c = base(); c.gain = 0.0f;      FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_PARAM, "gain");
    c = base(); c.bandwidth = 1e5f; FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_BANDWIDTH, "bandwidth above 1/Ts");
    c = base(); c.i_max = 0.0f;     FS_CHECK(fs_fw_init(&fw, &c) == FS_ERR_I_MAX, "i_max");
    FS_CHECK(fs_fw_init(NULL, &c) == FS_ERR_NULL, "null");
}

static void test_response(void)
{
    fs_fw fw;
    fs_fw_config c = base();
    c.gain = 3.0f;
    FS_CHECK(fs_fw_init(&fw, &c) == FS_OK, "init");
    const float w_e = 600.0f, dv = 20.0f;
    const double target = -(double)fw.beta * w_e * c.L * dv;
    FS_CHECK(target < 0.0 && target > -c.i_max, "target %g inside the limit", target);
    double a = exp(-(double)c.bandwidth * c.Ts);
    for (int k = 1; k <= 40; ++k) {
        float y = fs_fw_step(&fw, dv, w_e);
        double expect = target * (1.0 - pow(a, k));
        FS_CHECK_NEAR(y, expect, 1e-4 * fabs(target) + 1e-6, "first-order step response");
    }
    /* reversed rotation, where the excess has the sign of the speed */
    fs_fw_reset(&fw);
    for (int k = 0; k < 2000; ++k) fs_fw_step(&fw, -dv, -w_e);
    FS_CHECK_NEAR(fw.i_d, target, 1e-4 * fabs(target), "reverse: same d-current");
    /* leaves flux weakening by itself */
    for (int k = 0; k < 2000; ++k) fs_fw_step(&fw, 0.0f, -w_e);
    FS_CHECK(fabsf(fw.i_d) < 1e-3f * fabsf((float)target), "decays to zero: %g", fw.i_d);
    /* an excess against the speed never makes positive d-current */
    for (int k = 0; k < 2000; ++k) FS_CHECK(fs_fw_step(&fw, dv, -w_e) <= 0.0f, "never positive");
    /* limited */
    for (int k = 0; k < 2000; ++k) fs_fw_step(&fw, 1e4f, w_e);
    FS_CHECK_NEAR(fw.i_d, -c.i_max, 1e-6, "limited to -i_max");
}

int main(void)
{
    test_init();
    test_response();
    return fs_test_summary("test_fw");
}
