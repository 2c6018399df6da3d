% Three water tanks of 200, 125 and 75 litres: pour one into another until the first is
% empty or the second is full (the 8-5-3 jugs puzzle scaled by 25).  Integer fluents over
% a few hundred values linked by `where` arithmetic; written for the planner's benchmarks.

:- macros
  capA -> 200;
  capB -> 125;
  capC -> 75.

:- sorts
  tank;
  amount.

:- objects
  a, b, c                    :: tank;
  0..capA                    :: amount.

:- variables
  T                          :: tank;
  L, L1                      :: amount.

:- constants
  level(tank)                :: inertialFluent(amount);
  pour(tank, tank)           :: exogenousAction.

% pouring into a: everything, or until a is full
pour(T, a) causes level(a) = L1 + L if level(T) = L & level(a) = L1 where T \= a & L1 + L =< capA.
pour(T, a) causes level(T) = 0 if level(T) = L & level(a) = L1 where T \= a & L1 + L =< capA.
pour(T, a) causes level(a) = capA if level(T) = L & level(a) = L1 where T \= a & L1 + L > capA.
pour(T, a) causes level(T) = L - (capA - L1) if level(T) = L & level(a) = L1 where T \= a & L1 + L > capA.
% pouring into b: everything, or until b is full
pour(T, b) causes level(b) = L1 + L if level(T) = L & level(b) = L1 where T \= b & L1 + L =< capB & L1 =< capB.
pour(T, b) causes level(T) = 0 if level(T) = L & level(b) = L1 where T \= b & L1 + L =< capB & L1 =< capB.
pour(T, b) causes level(b) = capB if level(T) = L & level(b) = L1 where T \= b & L1 + L > capB & L1 =< capB.
pour(T, b) causes level(T) = L - (capB - L1) if level(T) = L & level(b) = L1 where T \= b & L1 + L > capB & L1 =< capB.
% pouring into c: everything, or until c is full
pour(T, c) causes level(c) = L1 + L if level(T) = L & level(c) = L1 where T \= c & L1 + L =< capC & L1 =< capC.
pour(T, c) causes level(T) = 0 if level(T) = L & level(c) = L1 where T \= c & L1 + L =< capC & L1 =< capC.
pour(T, c) causes level(c) = capC if level(T) = L & level(c) = L1 where T \= c & L1 + L > capC & L1 =< capC.
pour(T, c) causes level(T) = L - (capC - L1) if level(T) = L & level(c) = L1 where T \= c & L1 + L > capC & L1 =< capC.

nonexecutable pour(T, T).

constraint level(b) =< capB.
constraint level(c) =< capC.

noconcurrency.

:- query
  label :: 0;
  maxstep :: 0..10;
  0: level(a) = capA & level(b) = 0 & level(c) = 0;
  maxstep: level(a) = 100 & level(b) = 100.
