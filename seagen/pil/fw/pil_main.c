/* pil_main.c -- processor-in-the-loop firmware: one frame per 100 Hz tick over the UART.
 *
 * Host to board: A5 type n seq payload f16; board to host: 5A type n seq payload f16, where f16 is the
 * Fletcher-16 sum of every byte before it (little-endian). Types: 'R' reset (n x enc, pot: int32), 'T' tick
 * (n x enc, pot, force_q16: int32), 'D' set desired (n x desired_q16: int32), 'C' calibrate, 'X' exit. The
 * reply to R/T/D carries per actuator the command (int32 mV), the force estimate (int16), desired, comp,
 * pot_avg and fault (int32), then the SysTick counts of the tick's computation; the reply to C the counts of an
 * empty measurement and of a 2,000-instruction loop; a frame that fails its check gets an 'E' reply. */
#include "pil_board.h"
#include "pil_model.h"

#define PIL_HEAD 4u
#define PIL_IN_MAX (PIL_HEAD + 12u * PIL_N_MAX + 2u)
#define PIL_OUT_MAX (PIL_HEAD + 22u * PIL_N_MAX + 4u + 2u)

static pil_ctl_t pil_ctl[PIL_N_MAX];
#if PIL_HAS_CAL
static pil_cal_t pil_cal[PIL_N_MAX];
#endif
#if PIL_SHARED /* one feature pipeline per actuator, read by both models (pil_cal holds its state) */
static sea_features_out pil_feat[PIL_N_MAX];
#define PIL_FEAT(i) (&pil_feat[i])
#else
#define PIL_FEAT(i) 0
#endif
static int32_t pil_cmd[PIL_N_MAX];
static int16_t pil_est[PIL_N_MAX];
static uint8_t pil_in[PIL_IN_MAX];
static uint8_t pil_out[PIL_OUT_MAX];

static uint16_t pil_f16(const uint8_t *p, uint32_t n)
{
    uint32_t a = 0u, b = 0u, i;
    for (i = 0; i < n; ++i) {
        a = (a + p[i]) % 255u;
        b = (b + a) % 255u;
    }
    return (uint16_t)((b << 8) | a);
}

static int32_t pil_get32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24));
}

static uint8_t *pil_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
    return p + 4;
}

/* Payload bytes of a host frame of this type, or -1 for an unknown type. */
static int32_t pil_payload(uint8_t type, uint32_t n)
{
    switch (type) {
    case 'R': return (int32_t)(8u * n);
    case 'T': return (int32_t)(12u * n);
    case 'D': return (int32_t)(4u * n);
    case 'C':
    case 'X': return 0;
    default: return -1;
    }
}

static void pil_send(uint8_t type, uint8_t n, uint8_t seq, uint8_t *end)
{
    uint16_t f;
    pil_out[0] = 0x5Au;
    pil_out[1] = type;
    pil_out[2] = n;
    pil_out[3] = seq;
    f = pil_f16(pil_out, (uint32_t)(end - pil_out));
    end[0] = (uint8_t)f;
    end[1] = (uint8_t)(f >> 8);
    pil_tx(pil_out, (uint32_t)(end - pil_out) + 2u);
}

static uint32_t pil_elapsed(uint32_t t0, uint32_t t1)
{
    return (t0 - t1) & 0x00FFFFFFu; /* SysTick counts down */
}

static void pil_calibrate(uint8_t seq)
{
    uint32_t t0, t1, t2, t3, r = 1000u;
    t0 = pil_systick();
    t1 = pil_systick();
    t2 = pil_systick();
    __asm volatile(".syntax unified\n1: subs %0, %0, #1\n bne 1b" : "+l"(r)::"cc"); /* 2 instructions x 1,000 */
    t3 = pil_systick();
    pil_send('C', 0u, seq, pil_put32(pil_put32(pil_out + PIL_HEAD, pil_elapsed(t0, t1)), pil_elapsed(t2, t3)));
}

static void pil_reply(uint8_t type, uint32_t n, uint8_t seq, uint32_t counts)
{
    uint8_t *p = pil_out + PIL_HEAD;
    uint32_t i;
    for (i = 0; i < n; ++i) {
        const sea_control_state *s = PIL_CTL_STATE(&pil_ctl[i]);
        p = pil_put32(p, (uint32_t)pil_cmd[i]);
        p[0] = (uint8_t)(uint16_t)pil_est[i];
        p[1] = (uint8_t)((uint16_t)pil_est[i] >> 8);
        p = pil_put32(p + 2, (uint32_t)s->desired);
        p = pil_put32(p, (uint32_t)s->comp);
        p = pil_put32(p, (uint32_t)s->pot_avg);
        p = pil_put32(p, (uint32_t)s->fault);
    }
    pil_send(type, (uint8_t)n, seq, pil_put32(p, counts));
}

static void pil_tick(uint32_t n, const uint8_t *in)
{
    uint32_t i;
    for (i = 0; i < n; ++i) {
        const int32_t enc = pil_get32(in + 12u * i), pot = pil_get32(in + 12u * i + 4u);
        const int32_t force = pil_get32(in + 12u * i + 8u);
#if PIL_HAS_CAL
        pil_est[i] = PIL_CAL_STEP(&pil_cal[i], PIL_FEAT(i), enc, pot);
#endif
        pil_cmd[i] = PIL_CTL_TICK(&pil_ctl[i], enc, pot, force);
    }
}

/* Run one checked frame; returns 0 to go on, 1 to exit. */
static int pil_frame(uint8_t type, uint32_t n, uint8_t seq, const uint8_t *in)
{
    uint32_t i, t0, counts = 0u;
    switch (type) {
    case 'R':
        for (i = 0; i < n; ++i) {
#if PIL_HAS_CAL
            PIL_CAL_RESET(&pil_cal[i]);
#endif
            PIL_CTL_INIT(&pil_ctl[i], pil_get32(in + 8u * i), pil_get32(in + 8u * i + 4u), PIL_FEAT(i));
            pil_cmd[i] = 0;
            pil_est[i] = 0;
        }
        break;
    case 'T':
        t0 = pil_systick();
        pil_tick(n, in);
        counts = pil_elapsed(t0, pil_systick());
        break;
    case 'D':
        for (i = 0; i < n; ++i) {
            sea_control_set_desired(PIL_CTL_STATE_RW(&pil_ctl[i]), pil_get32(in + 4u * i));
        }
        break;
    case 'C': pil_calibrate(seq); return 0;
    default: pil_send('X', 0u, seq, pil_out + PIL_HEAD); return 1;
    }
    pil_reply(type, n, seq, counts);
    return 0;
}

static uint8_t pil_read(void)
{
    int b;
    while ((b = pil_rx()) < 0) {
        pil_rx_wait();
    }
    return (uint8_t)b;
}

int main(void)
{
    pil_board_init();
    for (;;) {
        uint32_t i, len;
        int32_t payload;
        pil_in[0] = pil_read();
        if (pil_in[0] != 0xA5u) {
            continue; /* resynchronise on the next start byte */
        }
        for (i = 1; i < PIL_HEAD; ++i) {
            pil_in[i] = pil_read();
        }
        payload = pil_payload(pil_in[1], pil_in[2]);
        if (payload < 0 || pil_in[2] > PIL_N_MAX) {
            pil_send('E', 2u, pil_in[3], pil_out + PIL_HEAD);
            continue;
        }
        len = PIL_HEAD + (uint32_t)payload;
        for (i = PIL_HEAD; i < len + 2u; ++i) {
            pil_in[i] = pil_read();
        }
        if (pil_f16(pil_in, len) != (uint16_t)(pil_in[len] | (pil_in[len + 1u] << 8))) {
            pil_send('E', 1u, pil_in[3], pil_out + PIL_HEAD);
            continue;
        }
        if (pil_frame(pil_in[1], pil_in[2], pil_in[3], pil_in + PIL_HEAD)) {
            return 0;
        }
    }
}
