// bigbob.cc - the Player/Stage manual's rubbish collector, written for playerstage-rs
// against libplayerc++ 3.0.2: Bigbob wanders, keeps off things with its sonars, turns towards
// the biggest blob it sees, and when its tooth laser says something sits between its teeth it
// "collects" it: the nearest orange or carton is moved to the bin with SetPose2d.
//
//   make && ./bigbob [host] [port] [iterations]     (defaults: localhost 6665, run forever)
//
// Needs worlds/bigbob.cfg (or bigbob2.cfg) served by `player`.

#include <libplayerc++/playerc++.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

using namespace PlayerCc;

namespace {

const double kAvoidRange = 0.6;   // m: closer than this on a front sonar, turn away
const double kCruise = 0.3;       // m/s
const double kTurn = 0.6;         // rad/s
const char *kThings[] = {"orange1", "orange2", "orange3", "orange4", "orange5", "orange6",
                         "carton1", "carton2", "carton3", "carton4"};
const int kThingCount = sizeof(kThings) / sizeof(kThings[0]);

// Speed and turn rate for this cycle from the sonars (ranger:0: front-left, front-right,
// left corner, right corner) and the blobs; returns true when avoiding.
bool Steer(const RangerProxy &sonar, const BlobfinderProxy &eyes, double &speed,
           double &turn) {
  speed = kCruise;
  turn = 0.0;
  if (sonar.GetRangeCount() >= 4) {
    double left = std::min(sonar[0], sonar[2]);
    double right = std::min(sonar[1], sonar[3]);
    if (left < kAvoidRange || right < kAvoidRange) {
      speed = 0.0;
      turn = left < right ? -kTurn : kTurn;  // away from the nearer side
      return true;
    }
  }
  // Head for the biggest blob: the one with the widest bounding box.
  int best = -1;
  unsigned widest = 0;
  for (unsigned i = 0; i < eyes.GetCount(); ++i) {
    playerc_blobfinder_blob_t b = eyes.GetBlob(i);
    unsigned width = b.right > b.left ? b.right - b.left : 0;
    if (best < 0 || width > widest) {
      best = static_cast<int>(i);
      widest = width;
    }
  }
  if (best >= 0 && eyes.GetWidth() > 0) {
    playerc_blobfinder_blob_t b = eyes.GetBlob(best);
    double centre = eyes.GetWidth() / 2.0;
    // Positive when the blob is left of the image centre: turn left.
    turn = 0.01 * (centre - static_cast<double>(b.x));
    speed = kCruise * 0.5;
  } else {
    turn = 0.2;  // wander: a slow curve
  }
  return false;
}

// True when the tooth laser (ranger:1) sees something short of its maximum range.
bool SomethingBetweenTeeth(const RangerProxy &laser) {
  unsigned n = laser.GetRangeCount();
  for (unsigned i = 0; i < n; ++i) {
    if (laser[i] < 0.2) return true;
  }
  return false;
}

// Moves the thing nearest to the robot's teeth to the bin; returns its name or "".
std::string Collect(SimulationProxy &sim, int collected) {
  double rx, ry, ra;
  sim.GetPose2d(const_cast<char *>("bob1"), rx, ry, ra);
  double tx = rx + 1.0 * std::cos(ra), ty = ry + 1.0 * std::sin(ra);
  int nearest = -1;
  double best = 1.0;
  for (int i = 0; i < kThingCount; ++i) {
    double x, y, a;
    sim.GetPose2d(const_cast<char *>(kThings[i]), x, y, a);
    double d = std::hypot(x - tx, y - ty);
    if (d < best) {
      best = d;
      nearest = i;
    }
  }
  if (nearest < 0) return "";
  // The bin: a row along the cave's south edge.
  sim.SetPose2d(const_cast<char *>(kThings[nearest]), -7.0 + 0.4 * collected, -7.4, 0.0);
  return kThings[nearest];
}

}  // namespace

int main(int argc, char **argv) {
  std::string host = argc > 1 ? argv[1] : "localhost";
  int port = argc > 2 ? std::atoi(argv[2]) : 6665;
  long iterations = argc > 3 ? std::atol(argv[3]) : -1;
  try {
    PlayerClient robot(host, port);
    Position2dProxy base(&robot, 0);
    RangerProxy sonar(&robot, 0);
    BlobfinderProxy eyes(&robot, 0);
    RangerProxy laser(&robot, 1);
    SimulationProxy sim(&robot, 0);

    base.SetMotorEnable(true);
    base.RequestGeom();
    sonar.RequestGeom();
    laser.RequestConfigure();
    std::printf("bigbob: connected to %s:%d, %u sonars\n", host.c_str(), port,
                sonar.GetElementCount());

    int collected = 0, avoided = 0, saw_blobs = 0;
    for (long i = 0; iterations < 0 || i < iterations; ++i) {
      robot.Read();
      double speed, turn;
      if (Steer(sonar, eyes, speed, turn)) ++avoided;
      if (eyes.GetCount() > 0) ++saw_blobs;
      if (SomethingBetweenTeeth(laser)) {
        std::string what = Collect(sim, collected);
        if (!what.empty()) {
          ++collected;
          std::printf("bigbob: collected %s\n", what.c_str());
        }
      }
      base.SetSpeed(speed, turn);
    }
    base.SetSpeed(0, 0);
    std::printf("bigbob: pose %.2f %.2f %.2f, %d reads with blobs, %d avoiding, %d collected\n",
                base.GetXPos(), base.GetYPos(), base.GetYaw(), saw_blobs, avoided, collected);
  } catch (PlayerError &e) {
    std::cerr << "bigbob: " << e << std::endl;
    return 1;
  }
  return 0;
}
