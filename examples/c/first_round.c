/* first_round.c - the first data round after subscribing (issue 40), as a libplayerc (C)
 * client: on a cfg serving both Bigbobs on one port (bob1's sonars and laser as ranger:0 and
 * ranger:1, bob2's as ranger:2 and ranger:3, bob2's base as position2d:1), it syncs with the
 * server's steps (one round of bob2's odometry), subscribes the four rangers, asks each for
 * its geometry and reads ONCE. Every ranger must then hold its ranges: a client indexing
 * ranges[] right after that read crashes on a ranger left empty. Exit status 0 when all hold.
 *
 *   make && ./first_round [host] [port]       (defaults: localhost 6665)
 */
#define EXAMPLE_NAME "first_round"
#include "example.h"

#include <time.h>

int main(int argc, char **argv) {
  playerc_client_t *client = connect_from_args(argc, argv);
  if (client == NULL) return 1;

  playerc_position2d_t *bob2 = playerc_position2d_create(client, 1);
  if (playerc_position2d_subscribe(bob2, PLAYER_OPEN_MODE) != 0) return fail("position2d:1");
  if (playerc_client_read(client) == NULL) return fail("the syncing read");
  /* As a client on a network or printing to a terminal: the robots' blocks are subscribed
   * well apart, still inside one step of the world. */
  struct timespec pause = {0, 40 * 1000 * 1000};
  nanosleep(&pause, NULL);

  playerc_ranger_t *rangers[4];
  for (int i = 0; i < 4; ++i) {
    rangers[i] = playerc_ranger_create(client, i);
    if (playerc_ranger_subscribe(rangers[i], PLAYER_OPEN_MODE) != 0) return fail("ranger");
  }
  for (int i = 0; i < 4; ++i) {
    if (playerc_ranger_get_geom(rangers[i]) != 0) return fail("ranger geometry");
  }
  if (playerc_client_read(client) == NULL) return fail("the first read");

  /* bigbob.inc: four one-sample sonars, a laser of 180 samples. */
  const unsigned expected[4] = {4, 180, 4, 180};
  for (int i = 0; i < 4; ++i) {
    playerc_ranger_t *r = rangers[i];
    printf("first_round: ranger:%d %u ranges, datatime %.3f\n", i, (unsigned)r->ranges_count,
           r->info.datatime);
    char what[64];
    snprintf(what, sizeof what, "ranger:%d holds its %u ranges", i, expected[i]);
    check(r->ranges != NULL && r->ranges_count == expected[i], what);
  }

  for (int i = 0; i < 4; ++i) {
    playerc_ranger_unsubscribe(rangers[i]);
    playerc_ranger_destroy(rangers[i]);
  }
  playerc_position2d_unsubscribe(bob2);
  playerc_position2d_destroy(bob2);
  playerc_client_disconnect(client);
  playerc_client_destroy(client);
  if (failures) return 1;
  printf("first_round: ok\n");
  return 0;
}
