/* log_control.c - a libplayerc (C) client for the log interface, as playervcr uses it: drives
 * a writelog device (start, stop, a new file only while stopped) or a readlog device (pause,
 * rewind, play), reading position2d:0 meanwhile. Exit status 0 when all went well.
 *
 *   make && ./log_control HOST PORT write NEWFILE     (writelog: log:0, autorecord 0)
 *   make && ./log_control HOST PORT read              (readlog: log:0, autoplay 1)
 */
#define EXAMPLE_NAME "log_control"
#include "example.h"

#include <string.h>

/* Reads `rounds` data rounds. */
static void read_rounds(playerc_client_t *client, int rounds) {
  for (int i = 0; i < rounds; ++i) {
    if (playerc_client_read(client) == NULL) break;
  }
}

int main(int argc, char **argv) {
  if (argc < 4) {
    fprintf(stderr, "usage: log_control HOST PORT write NEWFILE | read\n");
    return 2;
  }
  playerc_client_t *client = connect_from_args(argc, argv);
  if (client == NULL) return 1;
  playerc_log_t *log = playerc_log_create(client, 0);
  if (playerc_log_subscribe(log, PLAYER_OPEN_MODE) != 0) return fail("log:0");
  playerc_position2d_t *base = playerc_position2d_create(client, 0);
  if (playerc_position2d_subscribe(base, PLAYER_OPEN_MODE) != 0) return fail("position2d:0");

  if (strcmp(argv[3], "write") == 0 && argc > 4) {
    check(playerc_log_get_state(log) == 0 && log->type == PLAYER_LOG_TYPE_WRITE &&
              log->state == 0,
          "writelog, stopped");
    check(playerc_log_set_write_state(log, 1) == 0, "start recording");
    check(playerc_log_get_state(log) == 0 && log->state == 1, "recording");
    check(playerc_log_set_filename(log, argv[4]) != 0, "no new file while recording");
    check(playerc_log_set_write_state(log, 0) == 0, "stop recording");
    check(playerc_log_set_filename(log, argv[4]) == 0, "new file");
    check(playerc_log_set_write_state(log, 1) == 0, "record to it");
    read_rounds(client, 20);
    check(playerc_log_set_write_state(log, 0) == 0, "stop again");
  } else if (strcmp(argv[3], "read") == 0) {
    check(playerc_log_get_state(log) == 0 && log->type == PLAYER_LOG_TYPE_READ &&
              log->state == 1,
          "readlog, playing");
    read_rounds(client, 3);
    check(playerc_log_set_read_state(log, 0) == 0, "pause");
    check(playerc_log_get_state(log) == 0 && log->state == 0, "paused");
    check(playerc_log_set_read_rewind(log) == 0, "rewind");
    check(playerc_log_set_read_state(log, 1) == 0, "play");
    base->info.fresh = 0;
    read_rounds(client, 5);
    check(base->info.fresh, "data after the rewind");
    printf("log_control: replayed pose %.3f %.3f %.3f at %.3f\n", base->px, base->py, base->pa,
           base->info.datatime);
  } else {
    fprintf(stderr, "unknown mode %s\n", argv[3]);
    return 2;
  }
  playerc_position2d_unsubscribe(base);
  playerc_position2d_destroy(base);
  playerc_log_unsubscribe(log);
  playerc_log_destroy(log);
  playerc_client_disconnect(client);
  playerc_client_destroy(client);
  if (failures == 0) printf("log_control: ok\n");
  return failures == 0 ? 0 : 1;
}
