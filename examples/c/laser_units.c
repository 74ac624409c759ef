/* laser_units.c - a laser SET_CONFIG in Player 2's units (issue 40), with two libplayerc (C)
 * clients of one server: the first reads laser:0's scans, the second sends the request of
 * libplayerc's own laser test (test_laser.c: -90..90 deg, resolution 100, range_res 1, meant
 * as hundredths of a degree and millimetres). Player 3 reads radians and metres, and the LMS200
 * driver refuses it; so must the server, and the first client's ranges must not change (the
 * robot stands still). Written for the Pioneer world of tests/common (laser:0 on r0, a wall
 * 2.85 m east of it). Exit status 0 when all went well.
 *
 *   make && ./laser_units [host] [port]       (defaults: localhost 6665)
 */
#define EXAMPLE_NAME "laser_units"
#include "example.h"

#include <math.h>
#include <string.h>

/* Reads until `fresh` is set or 200 rounds went by. */
static int read_until_fresh(playerc_client_t *client, playerc_device_t *dev) {
  dev->fresh = 0;
  for (int i = 0; i < 200 && !dev->fresh; ++i) {
    if (playerc_client_read(client) == NULL) return -1;
  }
  return dev->fresh ? 0 : -1;
}

int main(int argc, char **argv) {
  playerc_client_t *reader = connect_from_args(argc, argv);
  playerc_client_t *tester = connect_from_args(argc, argv);
  if (reader == NULL || tester == NULL) return 1;

  playerc_laser_t *reading = playerc_laser_create(reader, 0);
  playerc_laser_t *testing = playerc_laser_create(tester, 0);
  if (playerc_laser_subscribe(reading, PLAYER_OPEN_MODE) != 0) return fail("laser (reader)");
  if (playerc_laser_subscribe(testing, PLAYER_OPEN_MODE) != 0) return fail("laser (tester)");
  if (read_until_fresh(reader, &reading->info) != 0) return fail("a first scan");
  int count = reading->scan_count;
  if (count <= 0) return fail("a first scan with ranges");
  double *before = malloc(sizeof(double) * count);
  memcpy(before, reading->ranges, sizeof(double) * count);
  int fractional = 0;
  for (int i = 0; i < count; ++i) fractional += before[i] != floor(before[i]);
  printf("laser_units: %d ranges, %d not whole metres, range[90] %.3f\n", count, fractional,
         before[count / 2]);
  check(fractional > count / 2, "the ranges are as simulated");

  check(playerc_laser_set_config(testing, -M_PI / 2, M_PI / 2, 100, 1, 1, 10) != 0,
        "test_laser.c's configuration (Player 2 units) is refused");

  for (int round = 0; round < 3; ++round) {
    if (read_until_fresh(reader, &reading->info) != 0) return fail("a scan after the request");
    int same = reading->scan_count == count;
    for (int i = 0; same && i < count; ++i) same = fabs(reading->ranges[i] - before[i]) < 1e-6;
    printf("laser_units: after the request %d ranges, range[90] %.3f\n", reading->scan_count,
           reading->scan_count > count / 2 ? reading->ranges[count / 2] : -1.0);
    check(same, "the other client's ranges are unchanged");
  }
  free(before);

  playerc_laser_unsubscribe(testing);
  playerc_laser_unsubscribe(reading);
  playerc_laser_destroy(testing);
  playerc_laser_destroy(reading);
  playerc_client_disconnect(tester);
  playerc_client_disconnect(reader);
  playerc_client_destroy(tester);
  playerc_client_destroy(reader);
  if (failures) return 1;
  printf("laser_units: ok\n");
  return 0;
}
