/* stage_devices.c - a libplayerc (C) client for what Player's own client programs check of a
 * Stage robot: where odometry starts, how an actuator reports a goal beyond its limit, and the
 * laser interface on a Stage ranger (geometry, and configuration as a SICK LMS200 takes it).
 * Written for the Pioneer world of tests/common (r0 at (-6.946, -6.947, 45 deg) on odometry
 * with localization_origin [0 0 0 0]: position2d:0, laser:0, actarray:0 with max_position 0.5;
 * r1 on odometry from its own start: position2d:1). Exit status 0 when all went well.
 *
 *   make && ./stage_devices [host] [port]       (defaults: localhost 6665)
 */
#define EXAMPLE_NAME "stage_devices"
#include "example.h"

#include <math.h>

/* Reads until `fresh` is set or 200 rounds went by. */
static int read_until_fresh(playerc_client_t *client, playerc_device_t *dev) {
  dev->fresh = 0;
  for (int i = 0; i < 200 && !dev->fresh; ++i) {
    if (playerc_client_read(client) == NULL) return -1;
  }
  return dev->fresh ? 0 : -1;
}

static double deg(double rad) { return rad * 180.0 / M_PI; }

int main(int argc, char **argv) {
  playerc_client_t *client = connect_from_args(argc, argv);
  if (client == NULL) return 1;

  playerc_position2d_t *r0 = playerc_position2d_create(client, 0);
  playerc_position2d_t *r1 = playerc_position2d_create(client, 1);
  playerc_laser_t *laser = playerc_laser_create(client, 0);
  playerc_actarray_t *lift = playerc_actarray_create(client, 0);
  if (playerc_position2d_subscribe(r0, PLAYER_OPEN_MODE) != 0) return fail("position2d:0");
  if (playerc_position2d_subscribe(r1, PLAYER_OPEN_MODE) != 0) return fail("position2d:1");
  if (playerc_laser_subscribe(laser, PLAYER_OPEN_MODE) != 0) return fail("laser:0");
  if (playerc_actarray_subscribe(lift, PLAYER_OPEN_MODE) != 0) return fail("actarray:0");

  /* Odometry: the start pose in the localization_origin frame. */
  if (read_until_fresh(client, &r0->info) != 0 || read_until_fresh(client, &r1->info) != 0)
    return fail("odometry data");
  printf("stage_devices: r0 odometry %.3f %.3f %.6f\n", r0->px, r0->py, r0->pa);
  printf("stage_devices: r1 odometry %.3f %.3f %.6f\n", r1->px, r1->py, r1->pa);
  check(fabs(r0->px + 6.946) < 1e-3 && fabs(r0->py + 6.947) < 1e-3 && fabs(r0->pa - M_PI / 4) < 1e-6,
        "r0 starts at its world pose");
  check(fabs(r1->px) < 1e-6 && fabs(r1->py) < 1e-6 && fabs(r1->pa) < 1e-6,
        "r1 starts at zero");
  if (playerc_position2d_set_odom(r0, 1.0, 2.0, 0.5) != 0) return fail("set odometry");
  read_until_fresh(client, &r0->info);
  read_until_fresh(client, &r0->info);
  check(fabs(r0->px - 1.0) < 1e-6 && fabs(r0->py - 2.0) < 1e-6 && fabs(r0->pa - 0.5) < 1e-6,
        "set odometry lasts");

  /* The actuator: a goal beyond max_position is reported clamped. */
  if (playerc_actarray_get_geom(lift) != 0) return fail("actarray geometry");
  printf("stage_devices: lift limits %.2f %.2f\n", lift->actuators_geom[0].min,
         lift->actuators_geom[0].max);
  if (playerc_actarray_position_cmd(lift, 0, 1.0f) != 0) return fail("actarray command");
  read_until_fresh(client, &lift->info);
  read_until_fresh(client, &lift->info);
  printf("stage_devices: lift after MoveTo(0, 1.0): position %.2f speed %.2f state %d\n",
         lift->actuators_data[0].position, lift->actuators_data[0].speed,
         lift->actuators_data[0].state);
  check(lift->actuators_count == 1 && lift->actuators_data[0].speed == 0.5f &&
            lift->actuators_data[0].state == PLAYER_ACTARRAY_ACTSTATE_MOVING,
        "the goal is clamped to max_position");

  /* The laser on the ranger: the ranger's size, and SICK-style configuration. */
  if (playerc_laser_get_geom(laser) != 0) return fail("laser geometry");
  printf("stage_devices: laser at [%.3f %.3f %.3f] size [%.3f %.3f]\n", laser->pose[0],
         laser->pose[1], laser->pose[2], laser->size[0], laser->size[1]);
  check(fabs(laser->size[0] - 0.156) < 1e-9 && fabs(laser->size[1] - 0.155) < 1e-9,
        "the laser has the ranger's size");
  /* libplayerc++'s laser test configures -90..90 deg, "100" and "1" (Player 2's hundredths of
   * a degree and millimetres): the LMS200 driver refuses it, Player 3 counting radians and
   * metres. The same in Player 3's units is taken. */
  check(playerc_laser_set_config(laser, -M_PI / 2, M_PI / 2, 100, 1, 1, 10) != 0,
        "the libplayerc++ test's configuration (Player 2 units) is refused");
  check(playerc_laser_set_config(laser, -M_PI / 2, M_PI / 2, M_PI / 180, 0.01, 1, 10) == 0,
        "the same in radians and metres is accepted");
  double min, max, res, range_res, freq;
  unsigned char intensity;
  if (playerc_laser_get_config(laser, &min, &max, &res, &range_res, &intensity, &freq) != 0)
    return fail("laser get config");
  printf("stage_devices: laser config %.2f..%.2f deg by %.4f deg, range_res %.3f, intensity %d, "
         "%.1f Hz\n", deg(min), deg(max), deg(res), range_res, intensity, freq);
  check(rint(deg(min)) == -90 && rint(deg(max)) == 90 && fabs(range_res - 0.01) < 1e-6 &&
            intensity == 1,
        "the configuration reads back");
  check(playerc_laser_set_config(laser, -M_PI / 2, M_PI / 2, 0.25 * M_PI / 180, 0.01, 1, 10) != 0,
        "a resolution finer than the rays is refused");
  check(playerc_laser_set_config(laser, -M_PI / 4, M_PI / 4, 2 * res, 0.1, 0, 10) == 0,
        "every second ray of +-45 deg is accepted");
  for (int i = 0; i < 5; ++i) read_until_fresh(client, &laser->info);
  printf("stage_devices: laser scan %d rays from %.2f deg by %.4f deg, first range %.3f\n",
         laser->scan_count, deg(laser->scan_start), deg(laser->scan_res),
         laser->scan_count > 0 ? laser->ranges[0] : -1.0);
  check(laser->scan_count == 45 && fabs(laser->scan_res - 2 * res) < 1e-6, "the scan is narrowed");

  playerc_actarray_unsubscribe(lift);
  playerc_laser_unsubscribe(laser);
  playerc_position2d_unsubscribe(r1);
  playerc_position2d_unsubscribe(r0);
  playerc_client_disconnect(client);
  playerc_client_destroy(client);
  if (failures) {
    printf("stage_devices: %d checks failed\n", failures);
    return 1;
  }
  printf("stage_devices: ok\n");
  return 0;
}
