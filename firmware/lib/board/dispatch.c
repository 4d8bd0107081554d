#include "board/dispatch.h"

#include <stddef.h>
#include <string.h>

#include "board/port.h"
#include "port_inline.h"
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

/* The request being answered: its type (which the reply's CRC covers), seq and body's
 * length, and the cycle counter when its handling began (one read: frame_cycles' start, a
 * PONG's timestamp). Passed by value: its 8 bytes fit the registers a call passes, where
 * through a pointer the compiler copied the frame's header to the stack for every one. */
typedef struct {
    uint8_t type;
    uint16_t seq;
    uint8_t body_len;
    uint32_t at;
} request_t;

static const request_t unsolicited = {0, UNSOLICITED_SEQ, 0, 0};

/* A step's cycles: the cycle counter's, less the UART interrupts that landed in the
 * step (in lockstep the frames behind it arrive while it runs, and the last reply may
 * still be going out), so a step costs the same in lockstep as stop-and-wait. */
typedef struct {
    uint32_t start;
    uint16_t mark;
} stopwatch_t;

static inline void stopwatch_start(stopwatch_t *w)
{
    w->start = port_cycles();
    w->mark = port_irq_mark();
}

static inline uint32_t stopwatch_read(const stopwatch_t *w)
{
    uint16_t irq = port_irq_cycles(w->mark);
    return port_cycles() - w->start - irq;
}

/* A 32-bit count kept as its low byte and the rest: the low byte alone changes unless
 * it wraps, a quarter of the instructions of a 32-bit increment on the AVR (every
 * exchange counts twice). */
typedef struct {
    uint8_t low;
    uint32_t rest;
} count_t;

static inline void count_up(count_t *c)
{
    if (++c->low == 0u) {
        c->rest++;
    }
}

static inline uint32_t count_value(const count_t *c) { return (c->rest << 8) | c->low; }

static struct {
    frame_rx_t rx; /* the request being received, decoded and checked byte by byte */
    uint8_t body[VEHIL_MAX_BODY]; /* replies other than PONG and RESULT are packed here */
    const estimator_t *estimator; /* NULL until a CONFIG succeeds, then &loaded */
    estimator_t loaded;           /* the configured descriptor, copied from flash */
    uint8_t mode;
    uint16_t probe_cycles; /* cost of reading the cycle counter, subtracted from steps */
    uint32_t frame_start;  /* the cycle count when the frame being handled began */
    uint16_t overruns_reported;
    count_t rx_frames, tx_frames; /* the STATS reply's, filled in when it is packed */
    msg_stats_t stats;
} core;

/* A request's body, where the received frame holds it (a reply the board sends on its
 * own answers none). */
static inline const uint8_t *req_body(void) { return frame_body(&core.rx); }

/* The most parameter bytes a CONFIG may carry when it comes in parts. */
#define CONFIG_PARAMS_MAX 512u

/* The RESULT cache, and a CONFIG's parameters while they come in parts: one memory, as
 * the parts end the configuration in force and a step's result ends the parts. */
static struct {
    uint16_t next; /* index of the SAMPLE to step next */
    uint8_t count; /* results kept, the newest in slot head - 1 */
    uint8_t head;
    uint16_t staged; /* parameter bytes held from CONFIG_PARTs; 0 once a step writes here */
    union {
        struct {
            uint8_t len; /* 0: the body did not fit */
            uint8_t body[RESULT_CACHE_BODY];
        } slot[RESULT_CACHE];
        uint8_t params[CONFIG_PARAMS_MAX];
    } u;
} results;

VEHIL_STATIC_ASSERT(CONFIG_PARAMS_MAX <= sizeof results.u.slot,
                    "the staged parameters would make the RESULT cache larger");

static void results_clear(void) { results.next = results.count = results.head = 0; }

/* Where the next step writes its RESULT body: its cache slot if it fits there. */
static uint8_t *results_slot(uint16_t body_max)
{
    results.staged = 0;
    return body_max <= RESULT_CACHE_BODY ? results.u.slot[results.head].body : core.body;
}

static void results_keep(const uint8_t *body, uint8_t body_len)
{
    results.u.slot[results.head].len = body == results.u.slot[results.head].body ? body_len : 0u;
    results.head = (uint8_t)((results.head + 1u) % RESULT_CACHE);
    if (results.count < RESULT_CACHE) {
        results.count++;
    }
    results.next++;
}

/* The kept RESULT slot of the sample `behind` before the next one, or NULL. */
static const uint8_t *results_find(uint16_t behind, uint8_t *len)
{
    if (behind == 0u || behind > results.count) {
        return NULL;
    }
    uint8_t i = (uint8_t)((results.head + RESULT_CACHE - behind) % RESULT_CACHE);
    *len = results.u.slot[i].len;
    return *len != 0u ? results.u.slot[i].body : NULL;
}

/* A reply, encoded with its CRC straight into the TX buffer. */
static void send_body(request_t req, uint8_t type, const uint8_t *body, uint8_t body_len)
{
    frame_tx_t tx;
    frame_tx_begin(&tx, req.type, type, req.seq, body_len);
    frame_tx_bytes(&tx, body, body_len);
    frame_tx_end(&tx);
    count_up(&core.tx_frames);
}

static void send(request_t req, uint8_t type, uint8_t body_len)
{
    send_body(req, type, core.body, body_len);
}

static void send_ack(request_t req)
{
    msg_ack_t ack = {.request = req.type};
    msg_ack_pack(&ack, core.body);
    send(req, MSG_ACK, MSG_ACK_FIXED_SIZE);
}

static void send_error(request_t req, uint8_t code, uint16_t detail)
{
    msg_error_t err = {.code = code, .request = req.type, .detail = detail};
    msg_error_pack(&err, core.body);
    send(req, MSG_ERROR, MSG_ERROR_FIXED_SIZE);
    if (core.stats.errors_sent < UINT16_MAX) {
        core.stats.errors_sent++;
    }
}

static void send_info(request_t req)
{
    msg_info_t info = {
        .protocol = VEHIL_PROTOCOL_VERSION,
        .schema_hash = VEHIL_SCHEMA_HASH,
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
    send(req, MSG_INFO, MSG_INFO_FIXED_SIZE);
}

static void saturating_inc(uint16_t *counter)
{
    if (*counter < UINT16_MAX) {
        (*counter)++;
    }
}

static void on_hello(request_t r)
{
    if (r.body_len >= 1 && req_body()[0] != VEHIL_PROTOCOL_VERSION) {
        send_error(r, ERR_VERSION, VEHIL_PROTOCOL_VERSION);
    } else if (r.body_len != MSG_HELLO_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_HELLO_FIXED_SIZE);
    } else {
        send_info(r);
    }
}

static void on_ping(request_t r)
{
    const uint8_t room = VEHIL_MAX_BODY - MSG_PONG_FIXED_SIZE;
    if (r.body_len > room) {
        send_error(r, ERR_BAD_LENGTH, room);
        return;
    }
    /* The timestamp over the request's header (r holds what was in it), and the echo
     * from the request's body where it lies: one run through the encoder. */
    msg_pong_t pong = {.timestamp = r.at};
    msg_pong_pack(&pong, frame_echo_head(&core.rx));
    frame_tx_echo(&core.rx, r.type, MSG_PONG, r.seq, r.body_len);
    count_up(&core.tx_frames);
}
VEHIL_STATIC_ASSERT(MSG_PONG_FIXED_SIZE == FRAME_HEADER_SIZE, "frame_tx_echo's head is a PONG's");

/* Copies the parameter bytes a CONFIG(_PART) carries to `offset` of the staging area,
 * if they follow what it holds and fit; 0 when refused (and answered). */
static uint8_t take_params(request_t r, uint16_t offset, uint8_t head)
{
    uint8_t len = (uint8_t)(r.body_len - head);
    if (offset > results.staged) {
        send_error(r, ERR_OUT_OF_ORDER, results.staged);
        return 0;
    }
    if ((uint32_t)offset + len > CONFIG_PARAMS_MAX) {
        send_error(r, ERR_PARAMS_OVERSIZE, CONFIG_PARAMS_MAX);
        return 0;
    }
    memcpy(results.u.params + offset, req_body() + head, len);
    return 1;
}

static void on_config_part(request_t r)
{
    if (r.body_len < MSG_CONFIG_PART_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_CONFIG_PART_FIXED_SIZE);
        return;
    }
    msg_config_part_t part;
    msg_config_part_unpack(req_body(), &part);
    core.estimator = NULL; /* a new configuration begins: the old one ends */
    results_clear();       /* its slots are about to hold the parameters */
    if (take_params(r, part.offset, MSG_CONFIG_PART_FIXED_SIZE)) {
        results.staged = (uint16_t)(part.offset + r.body_len - MSG_CONFIG_PART_FIXED_SIZE);
        send_ack(r);
    }
}

static void on_config(request_t r)
{
    if (r.body_len < MSG_CONFIG_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_CONFIG_FIXED_SIZE);
        return;
    }
    msg_config_t cfg;
    msg_config_unpack(req_body(), &cfg);
    estimator_t desc, *est = &desc;
    if (!estimator_load(estimator_index(cfg.estimator), est)) {
        send_error(r, ERR_UNKNOWN_ESTIMATOR, cfg.estimator);
        return;
    }
    if (cfg.mode > 7u || (est->modes & (1u << cfg.mode)) == 0) {
        send_error(r, ERR_UNSUPPORTED_MODE, cfg.mode);
        return;
    }
    uint16_t params_len = (uint16_t)(est->n_params * ESTIMATOR_VALUE_SIZE);
    if (cfg.offset > params_len || r.body_len != MSG_CONFIG_FIXED_SIZE + params_len - cfg.offset) {
        send_error(r, ERR_BAD_LENGTH, (uint16_t)(MSG_CONFIG_FIXED_SIZE + params_len - cfg.offset));
        return;
    }
    const uint8_t *params = req_body() + MSG_CONFIG_FIXED_SIZE;
    if (cfg.offset > 0u) { /* the block's head came in CONFIG_PARTs: its tail joins it */
        if (!take_params(r, cfg.offset, MSG_CONFIG_FIXED_SIZE)) {
            return;
        }
        params = results.u.params;
    }
    core.estimator = NULL; /* a refused CONFIG leaves nothing half-configured */
    uint8_t bad = est->configure(estimator_state(), cfg.mode, params);
    if (bad != 0) {
        send_error(r, ERR_BAD_PARAM, (uint16_t)(bad - 1u));
        return;
    }
    core.loaded = desc;
    core.estimator = &core.loaded;
    core.mode = cfg.mode;
    results_clear(); /* the staged bytes stay until a step: a CONFIG sent again applies alike */
    send_ack(r);
}

static void on_reset(request_t r)
{
    if (r.body_len != MSG_RESET_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_RESET_FIXED_SIZE);
        return;
    }
    msg_reset_t m;
    msg_reset_unpack(req_body(), &m);
    if (m.what == RESET_WHAT_STATE) {
        if (core.estimator == NULL) {
            send_error(r, ERR_NOT_CONFIGURED, 0);
            return;
        }
        core.estimator->reset(estimator_state());
        results_clear();
        send_ack(r);
    } else if (m.what == RESET_WHAT_REBOOT || m.what == RESET_WHAT_HANG) {
        send_ack(r);
        port_flush();
        if (m.what == RESET_WHAT_REBOOT) {
            port_reboot();
        } else {
            port_hang();
        }
    } else {
        send_error(r, ERR_BAD_PARAM, 0);
    }
}

static void on_sample(request_t r)
{
    const estimator_t *est = core.estimator;
    if (est == NULL) {
        send_error(r, ERR_NOT_CONFIGURED, 0);
        return;
    }
    uint8_t in_len = (uint8_t)(r.body_len - MSG_SAMPLE_FIXED_SIZE);
    uint8_t want = (uint8_t)(est->n_inputs * ESTIMATOR_VALUE_SIZE);
    uint8_t out_max = (uint8_t)(est->n_outputs * ESTIMATOR_VALUE_SIZE);
    if (est->n_inputs == ESTIMATOR_ANY_LENGTH) {
        want = VEHIL_MAX_BODY - MSG_RESULT_FIXED_SIZE; /* the echo must fit a RESULT */
        if (r.body_len < MSG_SAMPLE_FIXED_SIZE || in_len > want) {
            send_error(r, ERR_BAD_LENGTH, (uint16_t)(MSG_SAMPLE_FIXED_SIZE + want));
            return;
        }
        out_max = in_len;
    } else if (r.body_len != MSG_SAMPLE_FIXED_SIZE + want) {
        send_error(r, ERR_BAD_LENGTH, (uint16_t)(MSG_SAMPLE_FIXED_SIZE + want));
        return;
    }
    msg_sample_t sample;
    msg_sample_unpack(req_body(), &sample);
    if (sample.index != results.next) {
        uint8_t len = 0;
        const uint8_t *kept = results_find((uint16_t)(results.next - sample.index), &len);
        if (kept == NULL) {
            send_error(r, ERR_OUT_OF_ORDER, results.next);
            return;
        }
        saturating_inc(&core.stats.replayed);
        send_body(r, MSG_RESULT, kept, len);
        return;
    }
    /* The step reads its inputs from the received frame and writes its outputs into
     * the RESULT cache slot the reply is sent from. */
    uint8_t *body = results_slot((uint16_t)(MSG_RESULT_FIXED_SIZE + out_max));
    uint8_t out_len = 0;
    stopwatch_t watch;
    stopwatch_start(&watch);
    uint8_t status = est->step(estimator_state(), req_body() + MSG_SAMPLE_FIXED_SIZE, in_len,
                               body + MSG_RESULT_FIXED_SIZE, &out_len);
    uint32_t elapsed = stopwatch_read(&watch);
    /* The probe's own cost is measured once at boot; a noisy host clock can undercut it,
     * and an emulated timer (QEMU) can even step back: both read as 0, never as a wrap. */
    uint32_t cycles = (int32_t)elapsed > (int32_t)core.probe_cycles ? elapsed - core.probe_cycles : 0u;
    msg_result_t res = {.status = status, .cycles = cycles};
    msg_result_pack(&res, body);
    uint8_t body_len = (uint8_t)(MSG_RESULT_FIXED_SIZE + out_len);
    results_keep(body, body_len);
    send_body(r, MSG_RESULT, body, body_len);
}

static void on_get_stats(request_t r)
{
    if (r.body_len != MSG_GET_STATS_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_GET_STATS_FIXED_SIZE);
        return;
    }
    core.stats.overruns = port_rx_overruns();
    core.stats.stack_size = port_stack_size();
    core.stats.stack_unused = port_stack_unused();
    core.stats.timestamp = port_cycles();
    core.stats.rx_frames = count_value(&core.rx_frames);
    core.stats.tx_frames = count_value(&core.tx_frames);
    msg_stats_pack(&core.stats, core.body);
    send(r, MSG_STATS, MSG_STATS_FIXED_SIZE);
}

static void on_set_baud(request_t r)
{
    if (r.body_len != MSG_SET_BAUD_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_SET_BAUD_FIXED_SIZE);
        return;
    }
    msg_set_baud_t b;
    msg_set_baud_unpack(req_body(), &b);
    uint16_t error = port_baud_error(b.baud);
    if (error != 0) {
        send_error(r, ERR_BAD_BAUD, error);
        return;
    }
    send_ack(r); /* at the old rate: the host switches when it has it */
    port_flush();
    port_set_baud(b.baud);
}

static void on_get_estimator(request_t r)
{
    if (r.body_len != MSG_GET_ESTIMATOR_FIXED_SIZE) {
        send_error(r, ERR_BAD_LENGTH, MSG_GET_ESTIMATOR_FIXED_SIZE);
        return;
    }
    estimator_t est;
    if (!estimator_load(req_body()[0], &est)) {
        send_error(r, ERR_BAD_PARAM, 0);
        return;
    }
    msg_estimator_t e = {
        .index = req_body()[0],
        .id = est.id,
        .modes = est.modes,
        .n_inputs = est.n_inputs,
        .n_outputs = est.n_outputs,
        .n_params = est.n_params,
    };
    msg_estimator_pack(&e, core.body);
    uint8_t name_len = estimator_name(req_body()[0], core.body + MSG_ESTIMATOR_FIXED_SIZE);
    send(r, MSG_ESTIMATOR, (uint8_t)(MSG_ESTIMATOR_FIXED_SIZE + name_len));
}

/* By compares, the requests a stream repeats first: a switch's jump table (libgcc's
 * __tablejump2__) takes ~30 cycles, more than this chain to its last request. */
static void handle(request_t r)
{
    uint8_t type = r.type;
    if (type == MSG_PING) {
        on_ping(r);
    } else if (type == MSG_SAMPLE) {
        on_sample(r);
    } else if (type == MSG_GET_STATS) {
        on_get_stats(r);
    } else if (type == MSG_CONFIG) {
        on_config(r);
    } else if (type == MSG_CONFIG_PART) {
        on_config_part(r);
    } else if (type == MSG_RESET) {
        on_reset(r);
    } else if (type == MSG_HELLO) {
        on_hello(r);
    } else if (type == MSG_SET_BAUD) {
        on_set_baud(r);
    } else if (type == MSG_GET_ESTIMATOR) {
        on_get_estimator(r);
    } else {
        send_error(r, ERR_UNKNOWN_TYPE, 0);
    }
}

/* vehil profile --functions --ping --per frame counts a frame's handling from the first
 * mark to the second (host/vehil/fnprofile/collect.py): marks, not a call, which cost a
 * frame ~60 cycles. */
static void end_of_frame(frame_status_t st)
{
    PORT_CODE_MARK(vehil_frame_begin);
    if (st == FRAME_OK) {
        const request_t req = {
            frame_type(&core.rx), frame_seq(&core.rx), frame_body_len(&core.rx), port_cycles(),
        };
        /* The start kept for the sum in memory: the request's own copy then need not
         * live across the handler, and a PONG's timestamp comes from registers. */
        core.frame_start = req.at;
        count_up(&core.rx_frames);
        handle(req);
        core.stats.frame_cycles += port_cycles() - core.frame_start;
    } else if (st == FRAME_OVERSIZE) {
        saturating_inc(&core.stats.oversize);
        send_error(unsolicited, ERR_OVERSIZE, FRAME_RAW_MAX);
    } else if (st == FRAME_BAD_COBS) {
        saturating_inc(&core.stats.cobs_errors);
    } else if (st == FRAME_BAD_CRC) {
        saturating_inc(&core.stats.crc_errors);
    }
    uint16_t overruns = port_rx_overruns();
    if (overruns != core.overruns_reported) {
        send_error(unsolicited, ERR_OVERRUN, (uint16_t)(overruns - core.overruns_reported));
        core.overruns_reported = overruns;
    }
    PORT_CODE_MARK(vehil_frame_end);
}

void dispatch_init(void)
{
    memset(&core, 0, sizeof core);
    frame_rx_reset(&core.rx, 0); /* requests answer nothing */
    stopwatch_t watch;
    stopwatch_start(&watch);
    core.probe_cycles = (uint16_t)stopwatch_read(&watch);
    core.overruns_reported = port_rx_overruns();
    send_info(unsolicited);
}

void dispatch_bytes(const uint8_t *data, uint8_t len)
{
    while (len > 0u) {
        frame_status_t st;
        uint8_t took = frame_rx_bytes(&core.rx, data, len, &st);
        port_rx_release(took); /* before a long step: the RX ring gets its room back */
        data += took;
        len = took < len ? (uint8_t)(len - took) : 0u; /* more: bytes that came in meanwhile */
        if (st != FRAME_MORE) {
            end_of_frame(st);
        }
    }
}
