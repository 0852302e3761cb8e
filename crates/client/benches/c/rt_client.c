/* Minimal protocol-1040 round-trip client: the reference for `fs020n bench`.
 *
 * Connects to 127.0.0.1:PORT (TCP_NODELAY), then N times: one write of the status poll
 * "0 0 0" (what fs020n-client sends), read until the reply is complete (14 blank-separated
 * fields, the last followed by a blank). Prints {"count": N, "rate_hz": R} and exits.
 * With PERIOD_US, one round trip every PERIOD_US microseconds on a fixed schedule
 * (clock_nanosleep): the reference for the client's CPU while streaming.
 * No error recovery beyond retrying the connect across the emulator's listen gaps.
 *
 *   cc -O2 -o rt_client rt_client.c && ./rt_client 10050 20000 [PERIOD_US]
 */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

/* One round trip; 0 on success. */
static int round_trip(int fd) {
    static const char poll[] = "0 0 0";
    char buf[1024];
    int fields = 0, in_field = 0;
    if (write(fd, poll, sizeof poll - 1) != (ssize_t)(sizeof poll - 1)) return -1;
    for (;;) {
        ssize_t n = read(fd, buf, sizeof buf);
        if (n <= 0) return -1;
        for (ssize_t i = 0; i < n; i++) {
            if (is_blank(buf[i])) {
                if (in_field && fields == 14) return 0;
                in_field = 0;
            } else if (!in_field) {
                in_field = 1;
                fields++;
            }
        }
    }
}

int main(int argc, char **argv) {
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: %s PORT COUNT [PERIOD_US]\n", argv[0]);
        return 2;
    }
    int port = atoi(argv[1]);
    long count = atol(argv[2]);
    long period_ns = argc == 4 ? atol(argv[3]) * 1000 : 0;
    struct sockaddr_in addr = {.sin_family = AF_INET, .sin_port = htons((unsigned short)port)};
    inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
    int fd = -1;
    /* The emulator listens in windows (and one session at a time): retry for up to 10 s. */
    for (int attempt = 0; attempt < 1000; attempt++) {
        fd = socket(AF_INET, SOCK_STREAM, 0);
        int one = 1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        if (connect(fd, (struct sockaddr *)&addr, sizeof addr) == 0 && round_trip(fd) == 0) break;
        close(fd);
        fd = -1;
        usleep(10000);
    }
    if (fd < 0) {
        fprintf(stderr, "cannot connect to 127.0.0.1:%d\n", port);
        return 1;
    }
    double start = now_s();
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    for (long k = 0; k < count; k++) {
        if (round_trip(fd) != 0) {
            fprintf(stderr, "link lost after %ld round trips\n", k);
            return 1;
        }
        if (period_ns > 0) {
            next.tv_nsec += period_ns;
            while (next.tv_nsec >= 1000000000L) {
                next.tv_nsec -= 1000000000L;
                next.tv_sec++;
            }
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
        }
    }
    double elapsed = now_s() - start;
    /* End the session politely (command 255), as fs020n does. */
    static const char end[] = "1040 255 0";
    if (write(fd, end, sizeof end - 1) > 0) {
        char buf[256];
        while (read(fd, buf, sizeof buf) > 0) {
        }
    }
    close(fd);
    printf("{\"count\": %ld, \"rate_hz\": %.1f}\n", count, count / elapsed);
    return 0;
}
