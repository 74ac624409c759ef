/* nav.c - a libplayerc (C) client of a navigation stack: a planner (wavefront) driving a
 * robot localised by amcl on a map. It reads amcl's hypotheses and particles, sends the planner
 * a goal, checks every waypoint of the plan against the map, waits for the planner to say it
 * is done, stops and restarts the robot through the planner, and tells amcl where the robot is.
 * Exit status 0 when all went well; each step prints a "nav:" line.
 *
 *   make && ./nav [host] [port] [gx gy ga(deg)]      (defaults: localhost 6665 -3 0 90)
 */
#define EXAMPLE_NAME "nav"
#include "example.h"

#include <math.h>
#include <time.h>

/* The hypothesis with the largest weight. */
static const player_localize_hypoth_t *best(const playerc_localize_t *loc) {
  const player_localize_hypoth_t *b = NULL;
  for (int i = 0; i < loc->hypoth_count; ++i)
    if (b == NULL || loc->hypoths[i].alpha > b->alpha) b = &loc->hypoths[i];
  return b;
}

int main(int argc, char **argv) {
  double gx = argc > 3 ? atof(argv[3]) : -3.0;
  double gy = argc > 4 ? atof(argv[4]) : 0.0;
  double ga = (argc > 5 ? atof(argv[5]) : 90.0) * M_PI / 180.0;
  time_t deadline = time(NULL) + 90;

  playerc_client_t *client = connect_from_args(argc, argv);
  if (client == NULL) return 1;
  playerc_planner_t *planner = playerc_planner_create(client, 0);
  playerc_localize_t *loc = playerc_localize_create(client, 0);
  playerc_map_t *map = playerc_map_create(client, 0);
  if (playerc_planner_subscribe(planner, PLAYER_OPEN_MODE) != 0) return fail("planner");
  if (playerc_localize_subscribe(loc, PLAYER_OPEN_MODE) != 0) return fail("localize");
  if (playerc_map_subscribe(map, PLAYER_OPEN_MODE) != 0) return fail("map");
  if (playerc_map_get_map(map) != 0) return fail("map data");
  printf("nav: map %dx%d at %.3f m\n", map->width, map->height, map->resolution);

  /* amcl publishes hypotheses as it updates; the robot is still, so wait for the first. */
  while (loc->hypoth_count == 0) {
    if (time(NULL) > deadline) return fail("waiting for hypotheses");
    if (playerc_client_read(client) == NULL) return fail("read");
  }
  const player_localize_hypoth_t *h = best(loc);
  printf("nav: %d hypotheses, best %.2f %.2f %.2f\n", loc->hypoth_count, h->mean.px, h->mean.py,
         h->mean.pa);

  if (playerc_localize_get_particles(loc) != 0) return fail("get particles");
  double weight = 0.0;
  for (int i = 0; i < loc->num_particles; ++i) weight += loc->particles[i].weight;
  printf("nav: %d particles, weights sum %.3f, mean %.2f %.2f\n", loc->num_particles, weight,
         loc->mean[0], loc->mean[1]);
  if (loc->num_particles <= 0 || fabs(weight - 1.0) > 1e-3) {
    fprintf(stderr, "nav: the particle set is not a distribution\n");
    return 1;
  }

  if (playerc_planner_set_cmd_pose(planner, gx, gy, ga) != 0) return fail("planner goal");
  int checked = 0;
  int disabled = 0;
  while (!(checked && planner->path_done)) {
    if (time(NULL) > deadline) {
      fprintf(stderr, "nav: not there in time: at %.2f %.2f, valid %d done %d\n", planner->px,
              planner->py, planner->path_valid, planner->path_done);
      return 1;
    }
    if (playerc_client_read(client) == NULL) return fail("read");
    if (planner->path_valid && !checked) {
      if (playerc_planner_get_waypoints(planner) != 0) return fail("get waypoints");
      for (int i = 0; i < planner->waypoint_count; ++i) {
        int ci = (int)floor((planner->waypoints[i][0] - map->origin[0]) / map->resolution);
        int cj = (int)floor((planner->waypoints[i][1] - map->origin[1]) / map->resolution);
        if (ci < 0 || cj < 0 || ci >= map->width || cj >= map->height ||
            map->cells[PLAYERC_MAP_INDEX(map, ci, cj)] != -1) {
          fprintf(stderr, "nav: waypoint %d (%.2f, %.2f) is not a free cell\n", i,
                  planner->waypoints[i][0], planner->waypoints[i][1]);
          return 1;
        }
      }
      printf("nav: goal %.2f %.2f %.2f, %d waypoints, all free cells\n", planner->gx, planner->gy,
             planner->ga, planner->waypoint_count);
      checked = 1;
    }
    /* Halfway through, stop the robot for a moment through the planner. */
    if (checked && !disabled && planner->curr_waypoint >= planner->waypoint_count / 2) {
      if (playerc_planner_enable(planner, 0) != 0) return fail("disable");
      for (int i = 0; i < 5; ++i)
        if (playerc_client_read(client) == NULL) return fail("read");
      if (playerc_planner_enable(planner, 1) != 0) return fail("enable");
      printf("nav: disabled and enabled at waypoint %d\n", planner->curr_waypoint);
      disabled = 1;
    }
  }
  h = best(loc);
  printf("nav: done at %.2f %.2f; amcl's best %.2f %.2f %.2f\n", planner->px, planner->py,
         h->mean.px, h->mean.py, h->mean.pa);

  /* Tell amcl the robot is half a metre further east; its next hypotheses start there. */
  double told[3] = {h->mean.px + 0.5, h->mean.py, h->mean.pa};
  double cov[3] = {1e-4, 1e-4, 1e-4};
  double before = loc->info.datatime;
  if (playerc_localize_set_pose(loc, told, cov) != 0) return fail("set pose");
  int seen = 0, moved = 0;
  while (seen < 5 && !moved) {
    if (time(NULL) > deadline) return fail("waiting for hypotheses after set pose");
    if (playerc_client_read(client) == NULL) return fail("read");
    if (loc->info.datatime > before && loc->info.fresh) {
      loc->info.fresh = 0;
      ++seen;
      h = best(loc);
      moved = hypot(h->mean.px - told[0], h->mean.py - told[1]) < 0.1;
    }
  }
  if (!moved) {
    fprintf(stderr, "nav: amcl did not take the pose it was given\n");
    return 1;
  }
  printf("nav: set pose %.2f %.2f taken\n", told[0], told[1]);

  playerc_map_unsubscribe(map);
  playerc_localize_unsubscribe(loc);
  playerc_planner_unsubscribe(planner);
  playerc_map_destroy(map);
  playerc_localize_destroy(loc);
  playerc_planner_destroy(planner);
  playerc_client_disconnect(client);
  playerc_client_destroy(client);
  printf("nav: ok\n");
  return 0;
}
