#include "board/dispatch.h"

#include <stddef.h>
#include <string.h>

#include "board/port.h"
#include "estimators/estimator.h"
#include "proto/frame.h"
#include "proto/messages.h"

#ifndef VEHIL_BUILD_ID
#define VEHIL_BUILD_ID 0u
#endif
#ifndef VEHIL_BUILD_DIRTY
#define VEHIL_BUILD_DIRTY 0u
#endif

/* A reply that cannot name its request (oversize frame, RX overrun) uses this seq. */
#define UNSOLICITED_SEQ 0u

/* RESULTs kept so a SAMPLE sent again (its reply was lost) is answered without
 * stepping the estimator twice; bodies longer than a slot are not kept. */
#define RESULT_CACHE 16u
#define RESULT_CACHE_BODY 40u

static struct {
    uint8_t rx[FRAME_WIRE_MAX]; /* the frame being received, still COBS-encoded */
    uint16_t rx_len;
    uint8_t discarding; /* an oversize frame: drop bytes up to the next delimiter */
    uint8_t body[VEHIL_MAX_BODY];
    uint8_t wire[FRAME_WIRE_MAX];
    const estimator_t *estimator; /* NULL until a CONFIG succeeds */
    uint8_t mode;
    uint16_t probe_cycles; /* cost of reading the cycle counter, subtracted from steps */
    uint16_t overruns_reported;
    msg_stats_t stats;
} core;

static struct {
    uint16_t next; /* index of the SAMPLE to step next */
    uint8_t count; /* results kept, the newest in slot head - 1 */
    uint8_t head;
    struct {
        uint8_t len; /* 0: the body did not fit */
        uint8_t body[RESULT_CACHE_BODY];
    } slot[RESULT_CACHE];
} results;

static void results_clear(void) { results.next = results.count = results.head = 0; }

static void results_keep(uint16_t body_len)
{
    results.slot[results.head].len = body_len <= RESULT_CACHE_BODY ? (uint8_t)body_len : 0u;
    memcpy(results.slot[results.head].body, core.body, results.slot[results.head].len);
    results.head = (uint8_t)((results.head + 1u) % RESULT_CACHE);
    if (results.count < RESULT_CACHE) {
        results.count++;
    }
    results.next++;
}

/* The kept RESULT of the sample `behind` before the next one, or 0 if there is none. */
static uint8_t results_find(uint16_t behind)
{
    if (behind == 0u || behind > results.count) {
        return 0;
    }
    uint8_t i = (uint8_t)((results.head + RESULT_CACHE - behind) % RESULT_CACHE);
    memcpy(core.body, results.slot[i].body, results.slot[i].len);
    return results.slot[i].len;
}

static void send(uint8_t type, uint8_t seq, uint16_t body_len)
{
    uint16_t n = frame_encode(type, seq, core.body, body_len, core.wire);
    port_write(core.wire, n);
    core.stats.tx_frames++;
}

static void send_ack(uint8_t seq, uint8_t request)
{
    msg_ack_t ack = {.request = request};
    msg_ack_pack(&ack, core.body);
    send(MSG_ACK, seq, MSG_ACK_FIXED_SIZE);
}

static void send_error(uint8_t seq, uint8_t request, uint8_t code, uint16_t detail)
{
    msg_error_t err = {.code = code, .request = request, .detail = detail};
    msg_error_pack(&err, core.body);
    send(MSG_ERROR, seq, MSG_ERROR_FIXED_SIZE);
    if (core.stats.errors_sent < UINT16_MAX) {
        core.stats.errors_sent++;
    }
}

static void send_info(uint8_t seq)
{
    msg_info_t info = {
        .protocol = VEHIL_PROTOCOL_VERSION,
        .fw_major = VEHIL_FW_MAJOR,
        .fw_minor = VEHIL_FW_MINOR,
        .fw_patch = VEHIL_FW_PATCH,
        .build_id = VEHIL_BUILD_ID,
        .build_dirty = VEHIL_BUILD_DIRTY,
        .f_cpu = port_cycles_per_second(),
        .baud = port_baud(),
        .max_body = VEHIL_MAX_BODY,
        .rx_buffer = port_rx_buffer(),
        .free_ram = port_free_ram(),
        .boot_count = port_boot_count(),
        .reset_cause = port_reset_cause(),
        .estimators = estimator_count(),
        .probe_cycles = core.probe_cycles,
        .result_cache = RESULT_CACHE,
    };
    msg_info_pack(&info, core.body);
    send(MSG_INFO, seq, MSG_INFO_FIXED_SIZE);
}

static void saturating_inc(uint16_t *counter)
{
    if (*counter < UINT16_MAX) {
        (*counter)++;
    }
}

static void on_hello(const frame_t *f)
{
    if (f->body_len >= 1 && f->body[0] != VEHIL_PROTOCOL_VERSION) {
        send_error(f->seq, f->type, ERR_VERSION, VEHIL_PROTOCOL_VERSION);
    } else if (f->body_len != MSG_HELLO_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_HELLO_FIXED_SIZE);
    } else {
        send_info(f->seq);
    }
}

static void on_ping(const frame_t *f)
{
    const uint16_t room = VEHIL_MAX_BODY - MSG_PONG_FIXED_SIZE;
    if (f->body_len > room) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, room);
        return;
    }
    msg_pong_t pong = {.timestamp = port_cycles()};
    msg_pong_pack(&pong, core.body);
    memcpy(core.body + MSG_PONG_FIXED_SIZE, f->body, f->body_len);
    send(MSG_PONG, f->seq, (uint16_t)(MSG_PONG_FIXED_SIZE + f->body_len));
}

static void on_config(const frame_t *f)
{
    if (f->body_len < MSG_CONFIG_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_CONFIG_FIXED_SIZE);
        return;
    }
    msg_config_t cfg;
    msg_config_unpack(f->body, &cfg);
    const estimator_t *est = estimator_by_id(cfg.estimator);
    if (est == NULL) {
        send_error(f->seq, f->type, ERR_UNKNOWN_ESTIMATOR, cfg.estimator);
        return;
    }
    if (cfg.mode > 7u || (est->modes & (1u << cfg.mode)) == 0) {
        send_error(f->seq, f->type, ERR_UNSUPPORTED_MODE, cfg.mode);
        return;
    }
    uint16_t params_len = (uint16_t)(est->n_params * ESTIMATOR_VALUE_SIZE);
    if (f->body_len != MSG_CONFIG_FIXED_SIZE + params_len) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, (uint16_t)(MSG_CONFIG_FIXED_SIZE + params_len));
        return;
    }
    core.estimator = NULL; /* a refused CONFIG leaves nothing half-configured */
    uint8_t bad = est->configure(estimator_state(), cfg.mode, f->body + MSG_CONFIG_FIXED_SIZE);
    if (bad != 0) {
        send_error(f->seq, f->type, ERR_BAD_PARAM, (uint16_t)(bad - 1u));
        return;
    }
    core.estimator = est;
    core.mode = cfg.mode;
    results_clear();
    send_ack(f->seq, f->type);
}

static void on_reset(const frame_t *f)
{
    if (f->body_len != MSG_RESET_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_RESET_FIXED_SIZE);
        return;
    }
    msg_reset_t r;
    msg_reset_unpack(f->body, &r);
    if (r.what == 0) {
        if (core.estimator == NULL) {
            send_error(f->seq, f->type, ERR_NOT_CONFIGURED, 0);
            return;
        }
        core.estimator->reset(estimator_state());
        results_clear();
        send_ack(f->seq, f->type);
    } else if (r.what == 1 || r.what == 2) {
        send_ack(f->seq, f->type);
        port_flush();
        if (r.what == 1) {
            port_reboot();
        } else {
            port_hang();
        }
    } else {
        send_error(f->seq, f->type, ERR_BAD_PARAM, 0);
    }
}

static void on_sample(const frame_t *f)
{
    const estimator_t *est = core.estimator;
    if (est == NULL) {
        send_error(f->seq, f->type, ERR_NOT_CONFIGURED, 0);
        return;
    }
    uint16_t in_len = (uint16_t)(f->body_len - MSG_SAMPLE_FIXED_SIZE);
    uint16_t want = (uint16_t)(est->n_inputs * ESTIMATOR_VALUE_SIZE);
    if (est->n_inputs == ESTIMATOR_ANY_LENGTH) {
        want = VEHIL_MAX_BODY - MSG_RESULT_FIXED_SIZE; /* the echo must fit a RESULT */
        if (f->body_len < MSG_SAMPLE_FIXED_SIZE || in_len > want) {
            send_error(f->seq, f->type, ERR_BAD_LENGTH, (uint16_t)(MSG_SAMPLE_FIXED_SIZE + want));
            return;
        }
    } else if (f->body_len != MSG_SAMPLE_FIXED_SIZE + want) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, (uint16_t)(MSG_SAMPLE_FIXED_SIZE + want));
        return;
    }
    msg_sample_t sample;
    msg_sample_unpack(f->body, &sample);
    if (sample.index != results.next) {
        uint8_t len = results_find((uint16_t)(results.next - sample.index));
        if (len == 0u) {
            send_error(f->seq, f->type, ERR_OUT_OF_ORDER, results.next);
            return;
        }
        saturating_inc(&core.stats.replayed);
        send(MSG_RESULT, f->seq, len);
        return;
    }
    uint8_t out_len = 0;
    uint32_t start = port_cycles();
    uint8_t status = est->step(estimator_state(), f->body + MSG_SAMPLE_FIXED_SIZE, (uint8_t)in_len,
                               core.body + MSG_RESULT_FIXED_SIZE, &out_len);
    uint32_t elapsed = port_cycles() - start;
    /* The probe's own cost is measured once at boot; a noisy host clock can undercut it,
     * and an emulated timer (QEMU) can even step back: both read as 0, never as a wrap. */
    uint32_t cycles = (int32_t)elapsed > (int32_t)core.probe_cycles ? elapsed - core.probe_cycles : 0u;
    msg_result_t res = {.status = status, .cycles = cycles};
    msg_result_pack(&res, core.body);
    results_keep((uint16_t)(MSG_RESULT_FIXED_SIZE + out_len));
    send(MSG_RESULT, f->seq, (uint16_t)(MSG_RESULT_FIXED_SIZE + out_len));
}

static void on_get_stats(const frame_t *f)
{
    if (f->body_len != MSG_GET_STATS_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_GET_STATS_FIXED_SIZE);
        return;
    }
    core.stats.overruns = port_rx_overruns();
    core.stats.stack_size = port_stack_size();
    core.stats.stack_unused = port_stack_unused();
    core.stats.timestamp = port_cycles();
    msg_stats_pack(&core.stats, core.body);
    send(MSG_STATS, f->seq, MSG_STATS_FIXED_SIZE);
}

static void on_set_baud(const frame_t *f)
{
    if (f->body_len != MSG_SET_BAUD_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_SET_BAUD_FIXED_SIZE);
        return;
    }
    msg_set_baud_t b;
    msg_set_baud_unpack(f->body, &b);
    uint16_t error = port_baud_error(b.baud);
    if (error != 0) {
        send_error(f->seq, f->type, ERR_BAD_BAUD, error);
        return;
    }
    send_ack(f->seq, f->type); /* at the old rate: the host switches when it has it */
    port_flush();
    port_set_baud(b.baud);
}

static void on_get_estimator(const frame_t *f)
{
    if (f->body_len != MSG_GET_ESTIMATOR_FIXED_SIZE) {
        send_error(f->seq, f->type, ERR_BAD_LENGTH, MSG_GET_ESTIMATOR_FIXED_SIZE);
        return;
    }
    const estimator_t *est = estimator_at(f->body[0]);
    if (est == NULL) {
        send_error(f->seq, f->type, ERR_BAD_PARAM, 0);
        return;
    }
    msg_estimator_t e = {
        .index = f->body[0],
        .id = est->id,
        .modes = est->modes,
        .n_inputs = est->n_inputs,
        .n_outputs = est->n_outputs,
        .n_params = est->n_params,
    };
    msg_estimator_pack(&e, core.body);
    size_t name_len = strlen(est->name);
    memcpy(core.body + MSG_ESTIMATOR_FIXED_SIZE, est->name, name_len);
    send(MSG_ESTIMATOR, f->seq, (uint16_t)(MSG_ESTIMATOR_FIXED_SIZE + name_len));
}

static void handle(const frame_t *f)
{
    switch (f->type) {
    case MSG_HELLO: on_hello(f); break;
    case MSG_PING: on_ping(f); break;
    case MSG_CONFIG: on_config(f); break;
    case MSG_RESET: on_reset(f); break;
    case MSG_SAMPLE: on_sample(f); break;
    case MSG_GET_STATS: on_get_stats(f); break;
    case MSG_SET_BAUD: on_set_baud(f); break;
    case MSG_GET_ESTIMATOR: on_get_estimator(f); break;
    default: send_error(f->seq, f->type, ERR_UNKNOWN_TYPE, 0); break;
    }
}

static void end_of_frame(void)
{
    if (core.discarding) {
        core.discarding = 0;
        saturating_inc(&core.stats.oversize);
        send_error(UNSOLICITED_SEQ, 0, ERR_OVERSIZE, (uint16_t)sizeof core.rx);
        return;
    }
    if (core.rx_len == 0) {
        return; /* back-to-back delimiters: an idle line, not a frame */
    }
    uint32_t start = port_cycles();
    frame_t f;
    frame_status_t st = frame_decode(core.rx, core.rx_len, &f);
    core.rx_len = 0;
    if (st == FRAME_BAD_COBS) {
        saturating_inc(&core.stats.cobs_errors);
    } else if (st != FRAME_OK) {
        saturating_inc(&core.stats.crc_errors);
    } else {
        core.stats.rx_frames++;
        handle(&f);
    }
    core.stats.frame_cycles += port_cycles() - start;
    uint16_t overruns = port_rx_overruns();
    if (overruns != core.overruns_reported) {
        send_error(UNSOLICITED_SEQ, 0, ERR_OVERRUN, (uint16_t)(overruns - core.overruns_reported));
        core.overruns_reported = overruns;
    }
}

void dispatch_init(void)
{
    memset(&core, 0, sizeof core);
    uint32_t t0 = port_cycles();
    core.probe_cycles = (uint16_t)(port_cycles() - t0);
    core.overruns_reported = port_rx_overruns();
    send_info(UNSOLICITED_SEQ);
}

void dispatch_byte(uint8_t byte)
{
    if (byte == 0) {
        end_of_frame();
    } else if (core.discarding) {
        return;
    } else if (core.rx_len == sizeof core.rx) {
        core.discarding = 1;
        core.rx_len = 0;
    } else {
        core.rx[core.rx_len++] = byte;
    }
}
