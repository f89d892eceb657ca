/* sea_control.c -- the two-level controller (contract in sea_control.h); twin: controller.py. */
#include "sea_control.h"

static void sea_control_safe(const sea_control_config *c, sea_control_state *s, int32_t bits)
{
    s->fault |= bits;
    sea_pid_reset(&c->pid, &s->pid, s->comp, 0); /* integrator cleared, motor off */
    s->out = 0;
}

void sea_control_reset(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot)
{
    int i;
    s->pot_sum = 0;
    s->pot_idx = 0;
    s->pot_avg = pot;
    s->pred_count = 0;
    s->pred_idx = 0;
    s->enc_prev = enc;
    s->stuck_lo = 0;
    s->stuck_hi = 0;
    s->comp = sea_compression_q16(c->act, enc, pot);
    s->desired = s->comp;
    for (i = 0; i < SEA_CTRL_PRED_AVG_MAX; i++) {
        s->pred_buf[i] = s->comp;
    }
    s->fault = SEA_FAULT_NONE;
    sea_pid_reset(&c->pid, &s->pid, s->comp, 0);
    s->out = 0;
}

/* Fault bits raised by this tick's inputs (counters updated). */
static int32_t sea_control_check(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot,
                                 int32_t force_q16)
{
    int32_t bits = SEA_FAULT_NONE;
    int32_t need = (c->pot_stuck_ticks < 1) ? 1 : c->pot_stuck_ticks;
    int64_t jump = (int64_t)enc - s->enc_prev;
    s->enc_prev = enc;
    if ((jump > c->enc_jump_max) || (-jump > c->enc_jump_max)) {
        bits |= SEA_FAULT_ENC_JUMP;
    }
    s->stuck_lo = (pot <= 0) ? ((s->stuck_lo < need) ? (s->stuck_lo + 1) : need) : 0;
    s->stuck_hi = (pot >= c->act->pot_max) ? ((s->stuck_hi < need) ? (s->stuck_hi + 1) : need) : 0;
    if (s->stuck_lo >= need) {
        bits |= SEA_FAULT_POT_STUCK_LOW;
    }
    if (s->stuck_hi >= need) {
        bits |= SEA_FAULT_POT_STUCK_HIGH;
    }
    if ((force_q16 < c->force_min) || (force_q16 > c->force_max)) {
        bits |= SEA_FAULT_FORCE_RANGE;
    }
    return bits;
}

/* Push one pot reading; every act->pot_avg_ticks ticks refresh the average of the block (10 Hz). The sum of
 * at most 2^31 int32 readings fits int64 (pot_avg_ticks < 2^31). */
static void sea_control_pot(const sea_control_config *c, sea_control_state *s, int32_t pot)
{
    const int32_t n = (c->act->pot_avg_ticks < 1) ? 1 : c->act->pot_avg_ticks;
    s->pot_sum += pot;
    s->pot_idx += 1;
    if (s->pot_idx < n) {
        return;
    }
    s->pot_avg = sea_div_rne_s32(sea_sat32(s->pot_sum), n);
    s->pot_idx = 0;
    s->pot_sum = 0;
}

/* Push one prediction; the desired compression is the mean of the last n (rounded half to even). */
static void sea_control_predict(const sea_control_config *c, sea_control_state *s, int32_t pred)
{
    int64_t sum = 0;
    int32_t i;
    int32_t n = (c->pred_avg < 1) ? 1 : c->pred_avg;
    n = (n > SEA_CTRL_PRED_AVG_MAX) ? SEA_CTRL_PRED_AVG_MAX : n;
    s->pred_buf[s->pred_idx] = pred;
    s->pred_idx = ((s->pred_idx + 1) < n) ? (s->pred_idx + 1) : 0;
    for (i = 0; i < n; i++) {
        sum += s->pred_buf[i];
    }
    s->desired = sea_div_rne_s32(sea_sat32(sum), n);
}

int32_t sea_control_step(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot,
                         int32_t force_q16)
{
    int32_t bits;
    int32_t every = (c->predict_every < 1) ? 1 : c->predict_every;
    if (s->fault != SEA_FAULT_NONE) {
        return 0; /* latched safe state */
    }
    bits = sea_control_check(c, s, enc, pot, force_q16);
    if (bits != SEA_FAULT_NONE) {
        sea_control_safe(c, s, bits);
        return 0;
    }
    sea_control_pot(c, s, pot);
    s->comp = sea_compression_q16(c->act, enc, s->pot_avg);
    if ((c->predictor != NULL) && (s->pred_count == 0)) {
        sea_control_predict(c, s, c->predictor(c->predictor_ctx, enc, pot, force_q16));
    }
    s->pred_count = ((s->pred_count + 1) < every) ? (s->pred_count + 1) : 0;

    s->out = sea_pid_step(&c->pid, &s->pid, s->desired, s->comp);
    return s->out;
}
