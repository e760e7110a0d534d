/* A C client of cliffd: predicts two people in the demo hall and prints the first
 * sample of each, asks again with the options beyond the paper and a score per sample
 * and prints the most likely sample of each, shows how rejected requests read, and asks
 * the daemon to reload its maps.
 *
 * Build (from the repository root, after `cargo build --release -p cliff-client`):
 *   gcc client/examples/c/cliff_predict.c -I client/include \
 *       -L target/release -lcliff_client -Wl,-rpath,$PWD/target/release -o cliff_predict
 * Run (with `cliffd` running):
 *   ./cliff_predict [SERVICE [MAP]]        (defaults: cliff/predict, demo)
 * The iceoryx2 prefix comes from the CLIFF_IPC_PREFIX environment variable, if set.
 */
#include <stdio.h>
#include <stdlib.h>

#include "cliff_client.h"

int main(int argc, char **argv) {
    const char *service = argc > 1 ? argv[1] : "cliff/predict";
    const char *map = argc > 2 ? argv[2] : "demo";

    CliffClient *client = NULL;
    int rc = cliff_client_connect(service, NULL, &client);
    if (rc != CLIFF_OK) {
        fprintf(stderr, "connect failed (%d): %s\n", rc, cliff_last_error());
        return 2;
    }
    cliff_client_set_deadline_us(client, 2000000); /* 2 s */

    CliffParams params;
    cliff_params_default(&params);
    params.k = 5;
    params.seed = 42;
    CliffRequest *request = cliff_request_new(map, &params);
    if (!request) {
        fprintf(stderr, "bad request: %s\n", cliff_last_error());
        return 2;
    }

    /* person 0: a tracker with speed and heading, walking east */
    double t0[] = {0.0, 0.4, 0.8, 1.2};
    double x0[] = {-10.0, -9.5, -9.0, -8.5};
    double y0[] = {-1.0, -1.0, -1.0, -1.0};
    double s0[] = {1.25, 1.25, 1.25, 1.25};
    double h0[] = {0.0, 0.0, 0.0, 0.0};
    /* person 1: positions only, walking north */
    double t1[] = {0.0, 0.4, 0.8};
    double x1[] = {0.5, 0.5, 0.5};
    double y1[] = {-8.0, -7.5, -7.0};
    if (cliff_request_add_agent(request, 4, t0, x0, y0, s0, h0) != CLIFF_OK ||
        cliff_request_add_agent(request, 3, t1, x1, y1, NULL, NULL) != CLIFF_OK) {
        fprintf(stderr, "add agent: %s\n", cliff_last_error());
        return 2;
    }

    CliffPrediction p;
    rc = cliff_predict(client, request, &p);
    if (rc != CLIFF_OK) {
        fprintf(stderr, "predict failed (%d): %s\n", rc, cliff_last_error());
        return 1;
    }
    printf("request %llu: %u agents x %u samples x %u steps\n",
           (unsigned long long)p.request_id, p.agents, p.k, p.steps);
    for (uint32_t a = 0; a < p.agents; a++) {
        uint32_t sample = a * p.k; /* the first sample of agent a */
        uint32_t len = p.lens[sample];
        printf("agent %u sample 0: %u points:", a, len);
        for (uint32_t j = 0; j < len; j++) {
            const float *xy = p.positions + ((size_t)sample * p.steps + j) * 2;
            printf(" %.9g,%.9g", xy[0], xy[1]);
        }
        printf("\n");
    }
    cliff_prediction_release(client);

    /* the improved method with speed kernel, coasting and a score per sample, on the
     * all-day map */
    CliffParams scored = params;
    scored.method = CLIFF_METHOD_IMPROVED;
    scored.speed_beta = 2.0;
    scored.coast = 4.0;
    scored.flags = CLIFF_FLAG_SCORES;
    scored.time_mode = CLIFF_TIME_ALL_DAY;
    cliff_request_set_params(request, &scored);
    rc = cliff_predict(client, request, &p);
    if (rc != CLIFF_OK || p.scores == NULL) {
        fprintf(stderr, "scored predict failed (%d): %s\n", rc, cliff_last_error());
        return 1;
    }
    for (uint32_t a = 0; a < p.agents; a++) {
        int64_t best = cliff_prediction_best_sample(&p, a);
        printf("agent %u best sample %lld: score %.9g, %u points\n", a, (long long)best,
               p.scores[a * p.k + (uint32_t)best], p.lens[a * p.k + (uint32_t)best]);
    }
    cliff_prediction_release(client);

    /* a time mode the daemon does not know: refused, naming the status */
    scored.time_mode = 7;
    cliff_request_set_params(request, &scored);
    int bad_time = cliff_predict(client, request, &p);
    printf("unknown time mode: result %d, status %s\n", bad_time, cliff_status_name(p.status));

    /* a request for a map the daemon does not have */
    CliffRequest *bad = cliff_request_new("no-such-map", &params);
    cliff_request_add_agent(bad, 3, t1, x1, y1, NULL, NULL);
    rc = cliff_predict(client, bad, &p);
    printf("unknown map: result %d, status %s\n", rc, cliff_status_name(p.status));

    /* ask the daemon to reload its maps from their files (as SIGHUP does); a map whose
     * new file fails to load keeps its old version and the call says so */
    int reload = cliff_client_reload_maps(client);
    printf("reload maps: result %d%s%s\n", reload, reload == CLIFF_OK ? "" : ", ",
           reload == CLIFF_OK ? "" : cliff_last_error());

    cliff_request_free(bad);
    cliff_request_free(request);
    cliff_client_free(client);
    return rc == CLIFF_ERR_REJECTED && bad_time == CLIFF_ERR_REJECTED && reload == CLIFF_OK ? 0
                                                                                      : 1;
}
