/* basic.c - a small libplayerc (C) client for checking a Player server: subscribes to Bigbob's
 * base, sonars and the simulation, reads data, drives, moves a model with the simulation
 * interface and checks that it arrived, then unsubscribes. Exit status 0 when all went well.
 *
 *   make && ./basic [host] [port] [reads]       (defaults: localhost 6665 20)
 */
#define EXAMPLE_NAME "basic"
#include "example.h"

#include <math.h>

int main(int argc, char **argv) {
  int reads = argc > 3 ? atoi(argv[3]) : 20;
  playerc_client_t *client = connect_from_args(argc, argv);
  if (client == NULL) return 1;

  playerc_position2d_t *base = playerc_position2d_create(client, 0);
  playerc_ranger_t *sonar = playerc_ranger_create(client, 0);
  playerc_simulation_t *sim = playerc_simulation_create(client, 0);
  if (playerc_position2d_subscribe(base, PLAYER_OPEN_MODE) != 0) return fail("position2d");
  if (playerc_ranger_subscribe(sonar, PLAYER_OPEN_MODE) != 0) return fail("ranger");
  if (playerc_simulation_subscribe(sim, PLAYER_OPEN_MODE) != 0) return fail("simulation");
  if (playerc_client_set_replace_rule(client, -1, -1, PLAYER_MSGTYPE_DATA, -1, 1) != 0)
    return fail("replace rule");
  if (playerc_position2d_get_geom(base) != 0) return fail("position2d geometry");
  if (playerc_ranger_get_geom(sonar) != 0) return fail("ranger geometry");
  printf("basic: robot %.2f x %.2f m, %u sonars\n", base->size[0], base->size[1],
         (unsigned)sonar->element_count);

  playerc_position2d_set_cmd_vel(base, 0.0, 0.0, 0.5, 1);
  for (int i = 0; i < reads; ++i) {
    if (playerc_client_read(client) == NULL) return fail("read");
  }
  printf("basic: pose %.2f %.2f %.2f, %u ranges\n", base->px, base->py, base->pa,
         (unsigned)sonar->ranges_count);
  playerc_position2d_set_cmd_vel(base, 0.0, 0.0, 0.0, 1);

  double x, y, a;
  if (playerc_simulation_set_pose2d(sim, "carton1", 1.0, -2.0, 0.5) != 0) return fail("set pose");
  if (playerc_simulation_get_pose2d(sim, "carton1", &x, &y, &a) != 0) return fail("get pose");
  printf("basic: carton1 at %.2f %.2f %.2f\n", x, y, a);
  if (fabs(x - 1.0) > 1e-6 || fabs(y + 2.0) > 1e-6 || fabs(a - 0.5) > 1e-6) {
    fprintf(stderr, "basic: carton1 is not where it was put\n");
    return 1;
  }
  if (playerc_simulation_get_pose2d(sim, "no_such_model", &x, &y, &a) == 0) {
    fprintf(stderr, "basic: an unknown model was found\n");
    return 1;
  }

  playerc_simulation_unsubscribe(sim);
  playerc_ranger_unsubscribe(sonar);
  playerc_position2d_unsubscribe(base);
  playerc_simulation_destroy(sim);
  playerc_ranger_destroy(sonar);
  playerc_position2d_destroy(base);
  playerc_client_disconnect(client);
  playerc_client_destroy(client);
  printf("basic: ok\n");
  return 0;
}
