/* The reference server of the fleet benchmark (scripts/bench-fleet): N robot ports served by one
 * thread with epoll, every read answered with one fixed reply. It does no emulation at all, so
 * the emulator's CPU per reply divided by this server's is the cost of the emulation itself
 * beyond the kernel's loopback TCP.
 *
 * Listens on 127.0.0.1:BASE .. BASE+N-1 (SO_REUSEADDR, the emulator's 4096-byte send buffer,
 * TCP_NODELAY on accepted sockets, as `fs020n sim` sets them), accepts any number of
 * connections, and answers each read that returns data with the bytes of REPLY_FILE (one
 * `write`). Level-triggered epoll, up to 256 events per `epoll_wait`. Prints "ready" on stdout
 * once every port listens; runs until killed.
 *
 *   cc -O2 -o fixed_reply_server fixed_reply_server.c
 *   ./fixed_reply_server BASE N REPLY_FILE
 */
#define _GNU_SOURCE
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#define MAX_EVENTS 256
#define RECEIVE_BUFFER 4096

static void die(const char *what) {
    perror(what);
    exit(1);
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s BASE N REPLY_FILE\n", argv[0]);
        return 2;
    }
    int base = atoi(argv[1]);
    int n = atoi(argv[2]);
    if (base <= 0 || n <= 0 || base + n > 65536) {
        fprintf(stderr, "BASE and N must give ports within 1..65535\n");
        return 2;
    }
    static char reply[RECEIVE_BUFFER];
    FILE *f = fopen(argv[3], "rb");
    if (!f) die(argv[3]);
    size_t reply_len = fread(reply, 1, sizeof reply, f);
    fclose(f);
    if (reply_len == 0) {
        fprintf(stderr, "%s is empty\n", argv[3]);
        return 2;
    }

    int ep = epoll_create1(0);
    if (ep < 0) die("epoll_create1");
    /* A listener is marked by bit 32 of its event data. */
    int one = 1, sndbuf = 4096;
    for (int i = 0; i < n; i++) {
        int l = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
        if (l < 0) die("socket");
        setsockopt(l, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        setsockopt(l, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);
        struct sockaddr_in a = {0};
        a.sin_family = AF_INET;
        a.sin_port = htons((unsigned short)(base + i));
        a.sin_addr.s_addr = htonl(0x7f000001);
        if (bind(l, (struct sockaddr *)&a, sizeof a) < 0) die("bind");
        if (listen(l, 16) < 0) die("listen");
        struct epoll_event ev = {.events = EPOLLIN, .data.u64 = ((unsigned long long)1 << 32) | (unsigned)l};
        if (epoll_ctl(ep, EPOLL_CTL_ADD, l, &ev) < 0) die("epoll_ctl listener");
    }
    printf("ready\n");
    fflush(stdout);

    static char buf[RECEIVE_BUFFER];
    struct epoll_event events[MAX_EVENTS];
    for (;;) {
        int k = epoll_wait(ep, events, MAX_EVENTS, -1);
        if (k < 0) {
            if (errno == EINTR) continue;
            die("epoll_wait");
        }
        for (int i = 0; i < k; i++) {
            int fd = (int)(events[i].data.u64 & 0xffffffffu);
            if (events[i].data.u64 >> 32) {
                int c = accept4(fd, NULL, NULL, SOCK_NONBLOCK);
                if (c < 0) continue;
                setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
                struct epoll_event ev = {.events = EPOLLIN, .data.u64 = (unsigned)c};
                if (epoll_ctl(ep, EPOLL_CTL_ADD, c, &ev) < 0) close(c);
                continue;
            }
            ssize_t r = read(fd, buf, sizeof buf);
            if (r > 0) {
                if (write(fd, reply, reply_len) != (ssize_t)reply_len) {
                    epoll_ctl(ep, EPOLL_CTL_DEL, fd, NULL);
                    close(fd);
                }
            } else if (r == 0 || (errno != EAGAIN && errno != EINTR)) {
                epoll_ctl(ep, EPOLL_CTL_DEL, fd, NULL);
                close(fd);
            }
        }
    }
}
