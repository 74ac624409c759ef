/* example.h - what the example clients share: their messages carry the program's name
 * (EXAMPLE_NAME, defined before this is included), a tally of checks, the failure exit with
 * libplayerc's reason, and the connection to the server the command line names.
 */
#ifndef EXAMPLE_H
#define EXAMPLE_H

#include <libplayerc/playerc.h>

#include <stdio.h>
#include <stdlib.h>

/* How many checks failed so far. */
static int failures = 0;

/* Prints one check's outcome, counting it when it failed. */
static inline void check(int ok, const char *what) {
  printf(EXAMPLE_NAME ": %s: %s\n", what, ok ? "ok" : "FAILED");
  if (!ok) failures++;
}

/* Reports a libplayerc call that failed, with libplayerc's reason; returns the exit status. */
static inline int fail(const char *what) {
  fprintf(stderr, EXAMPLE_NAME ": %s failed: %s\n", what, playerc_error_str());
  return 1;
}

/* A client connected to the server at host argv[1] (default localhost), port argv[2]
 * (default 6665); NULL, reported, when it cannot connect. */
static inline playerc_client_t *connect_from_args(int argc, char **argv) {
  const char *host = argc > 1 ? argv[1] : "localhost";
  int port = argc > 2 ? atoi(argv[2]) : 6665;
  playerc_client_t *client = playerc_client_create(NULL, host, port);
  if (playerc_client_connect(client) != 0) {
    fail("connect");
    return NULL;
  }
  return client;
}

#endif
